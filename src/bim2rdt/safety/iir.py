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
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["compile_kernels", "sosfilt_rows", "weigh_rows"]


def sosfilt_rows(sos: np.ndarray, x: np.ndarray, zi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``scipy.signal.sosfilt(sos, x, axis=-1, zi=zi)`` for rows of samples, bit for bit.

    Args:
        sos: Second-order sections (k, 6), float64.
        x: Signals (rows, n), float32 or float64, C-contiguous, m/s^2; not changed.
        zi: Initial states (k, rows, 2); not changed.

    Returns:
        The filtered signals (rows, n) float64, and the final states (k, rows, 2).
    """
    out = np.empty(x.shape, dtype=np.float64)
    zf = np.array(zi, dtype=np.float64, order="C")
    _sosfilt(np.ascontiguousarray(sos, dtype=np.float64), np.ascontiguousarray(x), zf, out)
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
    _weigh(np.ascontiguousarray(sos, dtype=np.float64), x, zf, out, np.ascontiguousarray(starts, dtype=np.int64),
           top, bottom)
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


@njit(cache=True, nogil=True)
def _sosfilt(sos, x, zi, out):  # pragma: no cover - compiled
    """scipy's ``_sosfilt`` loop with ``x`` read once and the result written to ``out``; ``zi`` (k, rows, 2)
    becomes the final states. Each row's state is held in a local array while its samples run."""
    rows, n = x.shape
    sections = sos.shape[0]
    z = np.empty((sections, 2))
    for i in range(rows):
        z[:, :] = zi[:, i, :]
        for j in range(n):
            out[i, j] = _cascade(sos, z, np.float64(x[i, j]))
        zi[:, i, :] = z


@njit(cache=True, nogil=True)
def _weigh(sos, x, zi, out, starts, top, bottom):  # pragma: no cover - compiled
    """:func:`_sosfilt`, with each block's maximum and minimum of ``x`` kept on the way: a NaN, once met, stays the
    block's extreme (as numpy's ``max``/``min`` propagate it)."""
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
                if value > high or value != value:
                    if high == high:
                        high = value
                if value < low or value != value:
                    if low == low:
                        low = value
                out[i, j] = _cascade(sos, z, np.float64(value))
            top[i, b] = high
            bottom[i, b] = low
        zi[:, i, :] = z


def compile_kernels() -> None:
    """Compile (or load from the cache) the kernels for the monitor's float32 chunks and float64 corrected
    signals: ``make test`` calls it before the tests (``scripts/compile_kernels.py``), so no test with a deadline
    pays the first compile."""
    sos = np.array([[1.0, 0.0, 0.0, 1.0, 0.0, 0.0]])
    for dtype in (np.float32, np.float64):
        x = np.zeros((3, 4), dtype)
        weigh_rows(sos, x, np.zeros((1, 3, 2)), np.array([0, 2]))
        sosfilt_rows(sos, x, np.zeros((1, 3, 2)))
