"""One wearable's sample stream: order batches by seq, drop duplicates, declare gaps, cut analysis frames.

Real streams repeat batches (QoS 1 redelivery), reorder them, lose some and pause. A :class:`StreamBuffer`
holds out-of-order batches until the missing seq arrives or ``max_reorder`` later batches (or ``reorder_s``
seconds) have queued, then declares a gap. A gap (missing seq, a jump in device time, a change of rate) ends a
*segment*: exposure only counts sampled time, so the segment's tail frames are finished with zero padding and
a new segment starts. Within a segment the samples are cut into sine-tapered frames at a hop of half a frame;
a segment is padded by half a frame at each end (holding the edge sample, so gravity makes no step) so every
real sample is covered by exactly two frames.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np

from bim2rdt.bus.payloads import AccelBatch
from bim2rdt.safety.frames import FrameSpec

TIME_JUMP_S = 0.05
"""A device-time jump larger than this between consecutive batches is a pause in sampling (a gap)."""


@dataclass
class Gap:
    """Unsampled time in a stream: missing batches or a pause; its time is not counted as exposure."""

    start: float
    end: float
    reason: str
    missing_seqs: int = 0


@dataclass
class FrameBlock:
    """Frames cut from one stream: ``frames`` (F, 3, N) float32 m/s^2, ``end_time`` (F,) device time up to
    which each frame accounts, ``seconds`` (F,) sampled time each frame stands for."""

    frames: np.ndarray
    end_time: np.ndarray
    seconds: np.ndarray
    full_scale: float


@dataclass
class PushResult:
    """What one batch did to the stream: frames to weigh, duplicates/late batches dropped, gaps found."""

    blocks: list[FrameBlock] = field(default_factory=list)
    duplicates: int = 0
    late: int = 0
    gaps: list[Gap] = field(default_factory=list)


@dataclass
class Checkpoint:
    """Enough to rebuild a stream after a restart from the stored raw batches (seq >= ``resume_seq``)."""

    next_seq: int | None
    resume_seq: int | None
    resume_offset: int
    lead_zeros: int
    seg_t0: float
    fs: float


class StreamBuffer:
    """Ordering, gap detection and framing of one device's batches."""

    def __init__(self, device: str, max_reorder: int = 8, reorder_s: float = 2.0):
        self.device, self.max_reorder, self.reorder_s = device, max_reorder, reorder_s
        self.next_seq: int | None = None
        self.pending: dict[int, AccelBatch] = {}
        self.spec: FrameSpec | None = None
        self._skipped: deque[tuple[int, int]] = deque(maxlen=64)
        self._reset_segment()

    # --- ordering -------------------------------------------------------------------------------------
    def push(self, batch: AccelBatch, now: float) -> PushResult:
        """Accept one batch (any order); returns the frames that became complete."""
        result = PushResult()
        if self.next_seq is not None and (batch.seq < self.next_seq or batch.seq in self.pending):
            late = any(lo <= batch.seq < hi for lo, hi in self._skipped)
            result.late += int(late)
            result.duplicates += int(not late)
            return result
        self.pending[batch.seq] = batch
        self._drain(result, now)
        return result

    def expire(self, now: float, result: PushResult) -> None:
        """Declare a gap if the oldest waiting batch has waited longer than ``reorder_s``."""
        self._drain(result, now)

    def close(self, result: PushResult) -> None:
        """The device went away: take every waiting batch in order (gaps and all), then finish the segment."""
        while self.pending:
            self._drain(result, float("inf"))
        self._finish_segment(result)

    def _drain(self, result: PushResult, now: float) -> None:
        while self.pending:
            if self.next_seq is None:  # a new stream: seq 0 starts it, else wait for earlier ones
                if 0 not in self.pending and not self._must_skip(now):
                    return
                self.next_seq = min(self.pending)
            if self.next_seq in self.pending:
                self._append(self.pending.pop(self.next_seq), result)
                continue
            if not self._must_skip(now):
                return
            first = min(self.pending)
            missing = first - self.next_seq
            result.gaps.append(Gap(self._seg_time_end(), self.pending[first].device_time, "missing batches", missing))
            self._finish_segment(result)
            self._skipped.append((self.next_seq, first))
            self.next_seq = first

    def _must_skip(self, now: float) -> bool:
        oldest = min(b.received_time or now for b in self.pending.values())
        return len(self.pending) > self.max_reorder or now - oldest > self.reorder_s

    # --- segments and frames --------------------------------------------------------------------------
    def _append(self, batch: AccelBatch, result: PushResult) -> None:
        if self.spec is not None and self.seg_end > 0 and self._breaks_segment(batch):
            result.gaps.append(Gap(self._seg_time_end(), batch.device_time, self._break_reason(batch)))
            self._finish_segment(result)
        samples = np.ascontiguousarray(np.asarray(batch.xyz, dtype=np.float32).T)
        if self.seg_end == 0:
            self._start_segment(batch, samples)
        self._batches.append((batch.seq, self.seg_end, samples.shape[1]))
        self._parts.append(samples)
        self.seg_end += samples.shape[1]
        self.full_scale = batch.full_scale or float("inf")
        self.next_seq = batch.seq + 1
        self._cut(result, final=False)

    def _breaks_segment(self, batch: AccelBatch) -> bool:
        return batch.fs != self.spec.fs or abs(batch.device_time - self._seg_time_end()) > TIME_JUMP_S

    def _break_reason(self, batch: AccelBatch) -> str:
        return "sampling rate changed" if batch.fs != self.spec.fs else "device time jump"

    def _start_segment(self, batch: AccelBatch, samples: np.ndarray) -> None:
        self.spec = FrameSpec.for_rate(batch.fs)
        self.seg_t0 = batch.device_time
        self.buf_pos = -self.spec.hop
        self._parts = [_hold(samples[:, :1], self.spec.hop)]

    def _finish_segment(self, result: PushResult) -> None:
        if self.spec is not None and self.seg_end > 0:
            self._cut(result, final=True)
        self._reset_segment()

    def _reset_segment(self) -> None:
        self.seg_t0, self.seg_end, self.buf_pos = 0.0, 0, 0
        self.full_scale = float("inf")
        self._parts: list[np.ndarray] = []
        self._batches: deque[tuple[int, int, int]] = deque()

    def _seg_time_end(self) -> float:
        return self.seg_t0 + self.seg_end / self.spec.fs if self.spec else 0.0

    def _cut(self, result: PushResult, final: bool) -> None:
        """Cut every frame that starts before the data's end (``final``) or fits entirely (not final)."""
        n, hop = self.spec.length, self.spec.hop
        buf = np.concatenate(self._parts, axis=1) if len(self._parts) > 1 else self._parts[0]
        limit = self.seg_end if final else self.seg_end - n + 1
        starts = np.arange(self.buf_pos, limit, hop)
        if starts.size == 0:
            self._parts = [buf]
            return
        if final:
            buf = np.concatenate([buf, _hold(buf[:, -1:], starts[-1] + n - self.buf_pos - buf.shape[1])], axis=1)
        view = np.lib.stride_tricks.sliding_window_view(buf, n, axis=1)[:, starts - self.buf_pos]
        frames = np.ascontiguousarray(view.transpose(1, 0, 2))
        real = np.clip(np.minimum(starts + n, self.seg_end) - np.maximum(starts, 0), 0, None)
        end = self.seg_t0 + np.minimum(starts + 3 * hop // 2, self.seg_end) / self.spec.fs
        result.blocks.append(FrameBlock(frames, end, real / (2.0 * self.spec.fs), self.full_scale))
        consumed = int(starts[-1]) + hop - self.buf_pos
        self._parts = [buf[:, consumed:]]
        self.buf_pos += consumed
        while self._batches and self._batches[0][1] + self._batches[0][2] <= self.buf_pos:
            self._batches.popleft()

    # --- persistence ----------------------------------------------------------------------------------
    def checkpoint(self) -> Checkpoint:
        """Where to resume: the first batch (and sample in it) still needed by unfinished frames."""
        fs = self.spec.fs if self.spec else 0.0
        if not self._batches:
            return Checkpoint(self.next_seq, self.next_seq, 0, 0, self.seg_t0, fs)
        seq, start, _ = self._batches[0]
        offset = max(self.buf_pos - start, 0)
        lead = max(-self.buf_pos, 0) if start == 0 else 0
        return Checkpoint(self.next_seq, int(seq), int(offset), int(lead), float(self.seg_t0), float(fs))

    def restore(self, point: Checkpoint, batches: list[AccelBatch]) -> None:
        """Rebuild from a checkpoint and the stored batches with seq >= ``point.resume_seq``, in seq order."""
        self.next_seq = point.resume_seq
        if not batches or point.resume_seq is None:
            self.next_seq = point.next_seq
            return
        in_segment = [b for b in batches if b.seq < (point.next_seq or 0)]
        for batch in in_segment:
            self._restore_batch(batch, point, first=batch is in_segment[0])
        self.next_seq = point.next_seq
        self.pending = {b.seq: b for b in batches if b.seq >= (point.next_seq or 0)}

    def _restore_batch(self, batch: AccelBatch, point: Checkpoint, first: bool) -> None:
        samples = np.ascontiguousarray(np.asarray(batch.xyz, dtype=np.float32).T)
        if first:
            self.spec = FrameSpec.for_rate(batch.fs)
            self.seg_t0 = point.seg_t0
            start = int(round((batch.device_time - point.seg_t0) * batch.fs))
            self.seg_end = start
            self.buf_pos = start + point.resume_offset - point.lead_zeros
            self._parts = [_hold(samples[:, :1], point.lead_zeros), samples[:, point.resume_offset:]]
        else:
            self._parts.append(samples)
        self._batches.append((batch.seq, self.seg_end, samples.shape[1]))
        self.seg_end += samples.shape[1]
        self.full_scale = batch.full_scale or float("inf")


def _hold(edge: np.ndarray, count: int) -> np.ndarray:
    """``count`` copies of the (3, 1) edge sample: padding with no step (and no weighted energy)."""
    return np.repeat(edge, max(int(count), 0), axis=1).astype(np.float32)
