"""The weighting IIR's pass over a chunk of streams, compiled (numba): ``scipy.signal.sosfilt``'s arithmetic, bit for
bit, without its copy of the input.

``sosfilt`` first copies its input into a new float64 array and filters that copy in place. The monitor stacks a
chunk's samples as float32 (half the bytes for the block statistics, :mod:`~bim2rdt.safety.blocks`), so the copy
is also a conversion: a full extra pass over the chunk's memory. :func:`sosfilt_rows` reads each float32 (or
float64) sample once, converts it in a register and writes the filtered float64 sample, with the same operations
in the same order as scipy's kernel (transposed direct form II, section by section, one signal after another).
LLVM does not fuse the multiplications and additions (numba asks for no fast-math), so the output and the final
states equal ``sosfilt``'s exactly; tests/safety/test_iir.py checks it. Compiled once per machine and cached next
to this file (``cache=True``). :func:`weigh_rows` also takes each block's extremes of the samples on the way
(exact, as numpy's ``max``/``min``), so the block statistics need no separate pass for them.

The Wh filters of :func:`~bim2rdt.safety.filters.design_weighting` have two or three sections; for those the kernel
holds a row's six (or four) states in registers. scipy's loop, and the generic kernel here, keep them in memory,
and each sample then waits for its states to be stored and loaded again: the same operations take about 30 % less
time in registers (decision 0055).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["compile_kernels", "sosfilt_rows", "weigh_rows"]

_WHOLE_ROW = np.zeros(1, dtype=np.int64)
"""Block starts of one block a row: :func:`sosfilt_rows` runs :func:`weigh_rows`'s kernels."""


def sosfilt_rows(sos: np.ndarray, x: np.ndarray, zi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``scipy.signal.sosfilt(sos, x, axis=-1, zi=zi)`` for rows of samples, bit for bit.

    Args:
        sos: Second-order sections (k, 6), float64.
        x: Signals (rows, n), float32 or float64, C-contiguous, m/s^2; not changed.
        zi: Initial states (k, rows, 2); not changed.

    Returns:
        The filtered signals (rows, n) float64, and the final states (k, rows, 2).
    """
    x = np.ascontiguousarray(x)
    out = np.empty(x.shape, dtype=np.float64)
    zf = np.array(zi, dtype=np.float64, order="C")
    if x.shape[1] == 0:
        return out, zf
    top = np.empty((x.shape[0], 1), dtype=x.dtype)  # the pass's extremes, of one block a row, not returned
    _run(np.ascontiguousarray(sos, dtype=np.float64), x, zf, out, _WHOLE_ROW, top, np.empty_like(top))
    return out, zf


def weigh_rows(sos: np.ndarray, x: np.ndarray, zi: np.ndarray,
               starts: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """:func:`sosfilt_rows`, and the extremes of ``x`` in the blocks that start at ``starts``, in the same pass.

    Args:
        sos: Second-order sections (k, 6), float64.
        x: Signals (rows, n), float32 or float64, C-contiguous, m/s^2; not changed.
        zi: Initial states (k, rows, 2); not changed.
        starts: First sample of each block (b,), increasing from 0.

    Returns:
        The filtered signals (rows, n) float64, the final states (k, rows, 2), and the blocks' maxima and minima
        (rows, b) of ``x`` in its dtype: numpy's ``max`` and ``min`` exactly (NaN where a block holds a NaN).
    """
    x = np.ascontiguousarray(x)
    out = np.empty(x.shape, dtype=np.float64)
    zf = np.array(zi, dtype=np.float64, order="C")
    top = np.empty((x.shape[0], starts.size), dtype=x.dtype)
    bottom = np.empty_like(top)
    _run(np.ascontiguousarray(sos, dtype=np.float64), x, zf, out, np.ascontiguousarray(starts, dtype=np.int64), top,
         bottom)
    return out, zf, (top, bottom)


@njit(cache=True, nogil=True, inline="always")
def _cascade(sos, z, x_cur):  # pragma: no cover - compiled
    """One sample through the second-order sections, scipy's ``_sosfilt`` arithmetic operation for operation; the
    sections' states ``z`` (sections, 2) advance in place. Returns the filtered sample."""
    for s in range(sos.shape[0]):
        x_new = sos[s, 0] * x_cur + z[s, 0]
        z[s, 0] = sos[s, 1] * x_cur - sos[s, 4] * x_new + z[s, 1]
        z[s, 1] = sos[s, 2] * x_cur - sos[s, 5] * x_new
        x_cur = x_new
    return x_cur


@njit(cache=True, nogil=True, inline="always")
def _section(c, x_cur, z0, z1):  # pragma: no cover - compiled
    """One sample through one section whose coefficients ``c`` are (b0, b1, b2, a1, a2): :func:`_cascade`'s
    operations for one section, on states passed and returned as values (so they stay in registers). Returns the
    filtered sample and the section's two new states."""
    x_new = c[0] * x_cur + z0
    return x_new, c[1] * x_cur - c[3] * x_new + z1, c[2] * x_cur - c[4] * x_new


@njit(cache=True, nogil=True, inline="always")
def _extend(value, high, low):  # pragma: no cover - compiled
    """A block's running maximum and minimum with ``value``: a NaN, once met, stays (numpy's ``max``/``min``)."""
    if value > high or value != value:
        if high == high:
            high = value
    if value < low or value != value:
        if low == low:
            low = value
    return high, low


@njit(cache=True, nogil=True)
def _weigh(sos, x, zi, out, starts, top, bottom):  # pragma: no cover - compiled
    """scipy's ``_sosfilt`` loop (any number of sections) with ``x`` read once and the result written to ``out``,
    each block's maximum and minimum of ``x`` kept on the way; ``zi`` (k, rows, 2) becomes the final states. Each
    row's state is held in a local array while its samples run."""
    rows, n = x.shape
    sections, blocks = sos.shape[0], starts.size
    z = np.empty((sections, 2))
    for i in range(rows):
        z[:, :] = zi[:, i, :]
        for b in range(blocks):
            end = starts[b + 1] if b + 1 < blocks else n
            high = low = x[i, starts[b]]
            for j in range(starts[b], end):
                value = x[i, j]
                high, low = _extend(value, high, low)
                out[i, j] = _cascade(sos, z, np.float64(value))
            top[i, b] = high
            bottom[i, b] = low
        zi[:, i, :] = z


@njit(cache=True, nogil=True)
def _weigh2(c0, c1, x, zi, out, starts, top, bottom):  # pragma: no cover - compiled
    """:func:`_weigh` for two sections (the Wh filter below 3 kHz), the states in registers."""
    rows, n = x.shape
    blocks = starts.size
    for i in range(rows):
        z00, z01, z10, z11 = zi[0, i, 0], zi[0, i, 1], zi[1, i, 0], zi[1, i, 1]
        for b in range(blocks):
            end = starts[b + 1] if b + 1 < blocks else n
            high = low = x[i, starts[b]]
            for j in range(starts[b], end):
                value = x[i, j]
                high, low = _extend(value, high, low)
                y, z00, z01 = _section(c0, np.float64(value), z00, z01)
                out[i, j], z10, z11 = _section(c1, y, z10, z11)
            top[i, b] = high
            bottom[i, b] = low
        zi[0, i, 0], zi[0, i, 1], zi[1, i, 0], zi[1, i, 1] = z00, z01, z10, z11


@njit(cache=True, nogil=True)
def _weigh3(c0, c1, c2, x, zi, out, starts, top, bottom):  # pragma: no cover - compiled
    """:func:`_weigh` for three sections (the Wh filter from 3 kHz), the states in registers."""
    rows, n = x.shape
    blocks = starts.size
    for i in range(rows):
        z00, z01, z10, z11 = zi[0, i, 0], zi[0, i, 1], zi[1, i, 0], zi[1, i, 1]
        z20, z21 = zi[2, i, 0], zi[2, i, 1]
        for b in range(blocks):
            end = starts[b + 1] if b + 1 < blocks else n
            high = low = x[i, starts[b]]
            for j in range(starts[b], end):
                value = x[i, j]
                high, low = _extend(value, high, low)
                y, z00, z01 = _section(c0, np.float64(value), z00, z01)
                y, z10, z11 = _section(c1, y, z10, z11)
                out[i, j], z20, z21 = _section(c2, y, z20, z21)
            top[i, b] = high
            bottom[i, b] = low
        zi[0, i, 0], zi[0, i, 1], zi[1, i, 0], zi[1, i, 1] = z00, z01, z10, z11
        zi[2, i, 0], zi[2, i, 1] = z20, z21


def _run(sos: np.ndarray, x: np.ndarray, zf: np.ndarray, out: np.ndarray, starts: np.ndarray, top: np.ndarray,
         bottom: np.ndarray) -> None:
    """The pass with the kernel for ``sos``'s section count: two or three sections (every Wh filter that
    :func:`~bim2rdt.safety.filters.design_weighting` makes) with the states in registers, else :func:`_weigh`."""
    sections = [(float(s[0]), float(s[1]), float(s[2]), float(s[4]), float(s[5])) for s in sos]
    if len(sections) == 3:
        _weigh3(*sections, x, zf, out, starts, top, bottom)
    elif len(sections) == 2:
        _weigh2(*sections, x, zf, out, starts, top, bottom)
    else:
        _weigh(sos, x, zf, out, starts, top, bottom)


def compile_kernels() -> None:
    """Compile (or load from the cache) the kernels for the monitor's float32 chunks and float64 corrected
    signals: ``make test`` calls it before the tests (``scripts/compile_kernels.py``), so no test with a deadline
    pays the first compile."""
    for sections in (1, 2, 3):  # the generic kernel and the two in registers
        sos = np.tile([1.0, 0.0, 0.0, 1.0, 0.0, 0.0], (sections, 1))
        for dtype in (np.float32, np.float64):
            x = np.zeros((3, 4), dtype)
            weigh_rows(sos, x, np.zeros((sections, 3, 2)), np.array([0, 2]))
            sosfilt_rows(sos, x, np.zeros((sections, 3, 2)))
