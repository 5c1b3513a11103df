"""One wearable's batch stream: order by seq, drop duplicates, declare gaps, mark continuous segments.

Real streams repeat batches (QoS 1 redelivery), reorder them, lose some and pause. A :class:`StreamBuffer`
holds out-of-order batches until the missing seq arrives or ``max_reorder`` later batches (or ``reorder_s``
seconds) have queued, then declares a gap. A new stream starts at seq 0 at once, otherwise after the reorder
wait. A gap (missing seqs, a jump in device time, a change of rate) ends a *segment*: exposure counts sampled
time only, and the weighting filter restarts settled on the next sample.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

from bim2rdt.bus.payloads import AccelBatch

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
class PushResult:
    """Batches now in order (with whether each starts a new segment), duplicates/late dropped, gaps."""

    pieces: list[tuple[AccelBatch, bool]] = field(default_factory=list)
    duplicates: int = 0
    late: int = 0
    gaps: list[Gap] = field(default_factory=list)


class StreamBuffer:
    """Ordering and gap detection of one device's batches."""

    def __init__(self, max_reorder: int = 8, reorder_s: float = 2.0):
        self.max_reorder, self.reorder_s = max_reorder, reorder_s
        self.next_seq: int | None = None
        self.pending: dict[int, AccelBatch] = {}
        self.fs = 0.0
        self.end_time: float | None = None
        """Device time just after the last sample of the current segment (None: no open segment)."""
        self._skipped: deque[tuple[int, int]] = deque(maxlen=64)

    def push(self, batch: AccelBatch, now: float) -> PushResult:
        """Accept one batch (any order); returns the batches that are now next in line."""
        result = PushResult()
        if self.next_seq is not None and (batch.seq < self.next_seq or batch.seq in self.pending):
            late = any(lo <= batch.seq < hi for lo, hi in self._skipped)
            result.late, result.duplicates = int(late), int(not late)
            return result
        self.pending[batch.seq] = batch
        self._drain(result, now)
        return result

    def expire(self, now: float, result: PushResult) -> None:
        """Declare a gap if the oldest waiting batch has waited longer than ``reorder_s``."""
        self._drain(result, now)

    def close(self, result: PushResult) -> float | None:
        """The device went away: take every waiting batch in order (gaps and all) and end the segment; returns
        the device time just after its last sample (None if no segment was open)."""
        while self.pending:
            self._drain(result, float("inf"))
        end, self.end_time = self.end_time, None
        return end

    def _drain(self, result: PushResult, now: float) -> None:
        while self.pending:
            if self.next_seq is None:  # a new stream: seq 0 starts it, else wait for earlier ones
                if 0 not in self.pending and not self._must_skip(now):
                    return
                self.next_seq = min(self.pending)
            if self.next_seq in self.pending:
                self._take(self.pending.pop(self.next_seq), result)
                continue
            if not self._must_skip(now):
                return
            first = min(self.pending)
            start = self.end_time if self.end_time is not None else self.pending[first].device_time
            result.gaps.append(Gap(start, self.pending[first].device_time, "missing batches", first - self.next_seq))
            self._skipped.append((self.next_seq, first))
            self.end_time, self.next_seq = None, first

    def _must_skip(self, now: float) -> bool:
        oldest = min(b.received_time if b.received_time is not None else now for b in self.pending.values())
        return len(self.pending) > self.max_reorder or now - oldest > self.reorder_s

    def _take(self, batch: AccelBatch, result: PushResult) -> None:
        new_segment = self.end_time is None or batch.fs != self.fs
        if not new_segment and abs(batch.device_time - self.end_time) > TIME_JUMP_S:
            result.gaps.append(Gap(self.end_time, batch.device_time, "device time jump"))
            new_segment = True
        elif self.end_time is not None and batch.fs != self.fs:
            result.gaps.append(Gap(self.end_time, batch.device_time, "sampling rate changed"))
        self.fs, self.next_seq = batch.fs, batch.seq + 1
        self.end_time = batch.device_time + batch.duration_s
        result.pieces.append((batch, new_segment))

    def to_list(self) -> list:
        """[next seq, rate, segment end time, skipped seq ranges]: compact, saved with every ingest."""
        return [self.next_seq, self.fs, self.end_time, list(self._skipped)]

    def load(self, state: list, pending: list[AccelBatch]) -> None:
        self.next_seq, self.fs, self.end_time, skipped = state
        self._skipped.extend(tuple(pair) for pair in skipped)
        self.pending = {b.seq: b for b in pending if self.next_seq is None or b.seq >= self.next_seq}
