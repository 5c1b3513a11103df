"""Weigh many streams' new samples at once: one filtering pass per (rate, batch length, correction) group and chunk.

Each stream contributes at most one *run* of consecutive batches per *round* (its filter state comes from its
previous run), so a round of N devices' runs is a single (3N, n) filtering pass plus a few block reductions:
close to the cost of the bare ``sosfilt`` floor, whether N is large (many wearables) or the runs are long (a
group commit of one wearable's batches). The pass is :func:`~bim2rdt.safety.iir.sosfilt_rows`: ``sosfilt``'s
arithmetic bit for bit, reading the float32 samples once instead of through ``sosfilt``'s float64 copy.
The fitted Wh IIR (:mod:`bim2rdt.safety.filters`) keeps its state across batches, so a block's weighted energy
does not depend on how the stream was cut. NaN samples are replaced by the axis mean before filtering (their
blocks are rejected), and so are impossible ones (beyond the sensor's full scale or 5000 m/s^2), so the filter
never carries them on; a mounting correction runs first as a linear-phase FIR. A new segment (after a gap)
restarts the filters settled on its first sample.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
import scipy.signal

from bim2rdt.bus import AccelBatch
from bim2rdt.safety.blocks import (IMPOSSIBLE, NAN, REJECTED_BEFORE_SETTLING, SETTLING, ArtefactLimits, BlockStats,
                                   block_extremes, block_flags, block_moments, block_starts, block_stats, block_sums,
                                   has_bad_samples, replace_bad_samples, sample_limits)
from bim2rdt.safety.filters import design_weighting
from bim2rdt.safety.iir import sosfilt_rows, weigh_rows
from bim2rdt.safety.mounting import MountingCorrection


CHUNK = 128
"""Streams filtered per pass: the block passes re-read data still in cache, and the per-call overhead stays
small."""


@dataclass(slots=True)
class FilterState:
    """One stream's filter memories (IIR ``zi`` (k, 3, 2), FIR ``fir_zi`` (3, taps-1)) and whether its next
    block is still settling after an artefact."""

    zi: np.ndarray | None = None
    fir_zi: np.ndarray | None = None
    settle: bool = False

    def to_bytes(self) -> bytes:
        """Compact persistence: settle flag, section count, IIR state, then FIR state (float64)."""
        if self.zi is None:
            return struct.pack("<dd", float(self.settle), 0.0)
        blob = struct.pack("<dd", float(self.settle), float(self.zi.shape[0])) + self.zi.tobytes()
        return blob if self.fir_zi is None else blob + self.fir_zi.tobytes()

    @classmethod
    def from_bytes(cls, blob: bytes) -> FilterState:
        values = np.frombuffer(blob, dtype=np.float64)
        settle, sections = bool(values[0]), int(values[1])
        zi = values[2:2 + 6 * sections].reshape(sections, 3, 2).copy() if sections else None
        rest = values[2 + 6 * sections:]
        return cls(zi, rest.reshape(3, -1).copy() if rest.size else None, settle)


@dataclass(slots=True)
class Piece:
    """One stream's next in-order batches: a *run* of consecutive batches at one rate and sensor range, of which
    only the first may start a new segment; weighed in one pass with the stream's mounting correction."""

    state: FilterState
    batches: list[AccelBatch]
    new_segment: bool
    correction: MountingCorrection | None = None

    @property
    def lengths(self) -> tuple[int, ...]:
        batches = self.batches
        if len(batches) == 1:  # the usual run: one batch
            return (batches[0].xyz.shape[0],)
        return tuple([b.xyz.shape[0] for b in batches])

    @property
    def fs(self) -> float:
        return self.batches[0].fs

    @property
    def full_scale(self) -> float:
        return self.batches[0].full_scale or np.inf


@dataclass(slots=True)
class Blocks:
    """A piece's blocks: device ``end`` times, ``seconds`` of samples, weighted ``energy`` (m^2/s^3), ``flags``."""

    end: list[float] = field(default_factory=list)
    seconds: Sequence[float] = ()
    energy: list[float] = field(default_factory=list)
    flags: Sequence[int] = ()


@dataclass(frozen=True)
class _Layout:
    """Where the blocks of a run of batches with ``lengths`` samples lie: first samples of the blocks in the
    run, the batch each block belongs to, and each block's end (s) after its batch's first sample."""

    starts: np.ndarray
    batch: np.ndarray
    end_offset_s: np.ndarray
    seconds: tuple[float, ...]
    clean: tuple[int, ...]
    """No flag on any block: shared by every clean piece (one object fewer per stream and round for the collector)."""


@lru_cache(maxsize=256)
def _layout(lengths: tuple[int, ...], fs: float) -> _Layout:
    starts, batch, ends = [], [], []
    offset = 0
    for i, n in enumerate(lengths):
        own = block_starts(n, fs)
        starts.append(own + offset)
        batch += [i] * own.size
        ends += (np.append(own[1:], n) / fs).tolist()
        offset += n
    starts = np.concatenate(starts)
    seconds = np.diff(np.append(starts, offset)) / fs
    return _Layout(starts, np.array(batch, dtype=np.intp), np.array(ends), tuple(seconds.tolist()), (0,) * starts.size)


def weigh_round(pieces: list[Piece], limits: ArtefactLimits) -> list[Blocks]:
    """Filter a round (one piece per stream); each piece's blocks, in the order given."""
    groups: dict[tuple, list[int]] = {}
    for i, piece in enumerate(pieces):
        groups.setdefault((piece.fs, piece.lengths, piece.correction), []).append(i)
    out: list[Blocks | None] = [None] * len(pieces)
    for (fs, lengths, correction), members in groups.items():
        for first in range(0, len(members), CHUNK):  # cache-sized chunks: the block passes re-read hot data
            chunk = members[first:first + CHUNK]
            layout = _layout(lengths, fs)
            for i, blocks in zip(chunk, _weigh_group([pieces[i] for i in chunk], fs, layout, correction, limits)):
                out[i] = blocks
    return out


def _weigh_group(pieces: list[Piece], fs: float, layout: _Layout, correction: MountingCorrection | None,
                 limits: ArtefactLimits) -> list[Blocks]:
    raw = _stack(pieces)  # (3m, n)
    starts = layout.starts
    full_scale = np.array([p.full_scale for p in pieces])
    possible = sample_limits(full_scale, limits.physical_limit)
    sums, squares = block_moments(raw, starts)  # while the samples are in cache; the extremes come with the filter
    starting = [j for j, p in enumerate(pieces) if p.new_segment or p.state.zi is None]  # settled on their first
    weighted, zf, fir_zf, extremes = _filter(pieces, raw, fs, starts, correction, starting)
    stats, bad = BlockStats(sums, squares, extremes), None
    if has_bad_samples(sums, extremes, possible):  # rare: replace them, and weigh the chunk again without them
        bad = replace_bad_samples(raw, possible)
        stats = block_stats(raw, starts)
        weighted, zf, fir_zf, _ = _filter(pieces, raw, fs, starts, correction, starting)
    energy = block_sums(weighted, starts, square=True).reshape(len(pieces), 3, -1).sum(axis=1) / fs
    flags = block_flags(raw.shape[1], starts, stats, full_scale, limits)
    if bad is not None:
        flags |= np.where(np.logical_or.reduceat(bad[0], starts, axis=1), NAN, 0)
        flags |= np.where(np.logical_or.reduceat(bad[1], starts, axis=1), IMPOSSIBLE, 0)
    own = zf.reshape(zf.shape[0], len(pieces), 3, 2).transpose(1, 0, 2, 3)  # each stream's (k, 3, 2), one copy
    for j, (piece, zi_j) in enumerate(zip(pieces, np.ascontiguousarray(own))):
        piece.state.zi = zi_j
        if fir_zf is not None:
            piece.state.fir_zi = fir_zf[3 * j:3 * j + 3]
    first_times = np.array([[b.device_time for b in p.batches] for p in pieces])  # (m, batches of the run)
    ends = (first_times[:, layout.batch] + layout.end_offset_s).tolist()  # the same float additions, all at once
    flagged = flags.any(axis=1).tolist()
    return [_blocks(p, layout, t, e, flags[j].tolist() if x else layout.clean, x)
            for j, (p, t, e, x) in enumerate(zip(pieces, ends, energy.tolist(), flagged))]


def _filter(pieces: list[Piece], raw: np.ndarray, fs: float, starts: np.ndarray, correction: MountingCorrection | None,
            starting: list[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, tuple[np.ndarray, np.ndarray]]:
    """The chunk's weighted signal (3m, n), final IIR and FIR states (None without a correction) and the blocks'
    raw extremes (3m, k) each; the pieces at ``starting`` (segments that start here) are settled on their first
    sample first. The pieces' running states are the caller's to set from the returned ones, so a chunk can be
    weighed again (after its bad samples were replaced: the same pieces settled again on the new first samples)."""
    if starting:
        firsts = raw[:, 0].reshape(-1, 3).astype(np.float64)
        for j in starting:
            _settle(pieces[j], firsts[j], correction)
    zi = np.concatenate([p.state.zi for p in pieces], axis=1)
    sos = design_weighting(fs).sos
    if correction is None:
        weighted, zf, extremes = weigh_rows(sos, raw, zi, starts)  # sosfilt's, without its copy; extremes on the way
        return weighted, zf, None, extremes
    fir_zi = np.concatenate([p.state.fir_zi for p in pieces])
    signal, fir_zf = scipy.signal.lfilter(_fir(correction, fs), [1.0], raw, axis=-1, zi=fir_zi)
    weighted, zf = sosfilt_rows(sos, signal, zi)
    return weighted, zf, fir_zf, block_extremes(raw, starts)


def _stack(pieces: list[Piece]) -> np.ndarray:
    """The pieces' samples as one (3m, n) float32 array; 5x faster than concatenating transposed views."""
    lengths = pieces[0].lengths
    raw = np.empty((3 * len(pieces), sum(lengths)), dtype=np.float32)
    for j, piece in enumerate(pieces):
        offset = 0
        for batch, n in zip(piece.batches, lengths):
            raw[3 * j:3 * j + 3, offset:offset + n] = batch.xyz.T
            offset += n
    return raw


def _blocks(piece: Piece, layout: _Layout, ends: list[float], energy: list[float], flags: Sequence[int],
            flagged: bool) -> Blocks:
    """Attach device times (``ends``), and flag the block after each rejected one as settling."""
    if not piece.state.settle and not flagged:
        return Blocks(ends, layout.seconds, energy, flags)
    marked = []
    for flag in flags:
        marked.append(flag | (SETTLING if piece.state.settle else 0))
        piece.state.settle = bool(flag & REJECTED_BEFORE_SETTLING)
    return Blocks(ends, layout.seconds, energy, marked)


def _settle(piece: Piece, first: np.ndarray, correction: MountingCorrection | None) -> None:
    """Start a segment with both filters settled on the first sample (gravity enters without a step)."""
    fs = piece.fs
    piece.state.zi = design_weighting(fs).settled_state(first)
    piece.state.settle = False
    if correction is not None:
        taps = _fir(correction, fs)
        piece.state.fir_zi = scipy.signal.lfilter_zi(taps, [1.0])[None, :] * first[:, None]


@lru_cache(maxsize=64)
def _fir(correction: MountingCorrection, fs: float) -> np.ndarray:
    return correction.fir(fs)
