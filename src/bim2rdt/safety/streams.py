"""One wearable's batch stream: order by seq, drop duplicates, declare gaps, mark continuous segments.

Real streams repeat batches (QoS 1 redelivery), reorder them, lose some and pause. A :class:`StreamBuffer`
holds out-of-order batches until the missing seq arrives or ``max_reorder`` later batches (or ``reorder_s``
seconds) have queued, then declares a gap. A new stream starts at seq 0 at once, otherwise after the reorder
wait. A gap (missing seqs, a jump in device time, a change of rate) ends a *segment*: exposure counts sampled
time only, and the weighting filter restarts settled on the next sample.

Sequence numbers are checked against device time, which says what is new:
- a batch whose first sample time was taken or is waiting is a duplicate, whatever its seq (the times taken are
  kept as runs of evenly spaced batches, ``RUNS`` of them: a continuous stream is one run however long);
- a seq already taken (or waiting) whose samples start at or after everything seen is a *new numbering* (the
  device rebooted and counts from 0 again): what waits is flushed and the stream goes on from this batch;
- a low seq (under ``RESTART_SEQ``) whose samples start *before* what was seen, at a time never taken, is a
  device *restart with a reset clock* (a clock counting from boot): a new epoch, its own segment, counted;
- a device that says it restarted (a new ``boot`` in its status message, :meth:`StreamBuffer.announce_boot`)
  starts a new epoch with its next batch whose seq goes back, even where its times repeat the old epoch's
  exactly (a boot-relative clock on the same grid): the times of the old epoch are then forgotten;
- a seq far ahead whose samples continue the open segment without a pause is the next batch under a wrong
  number (one corrupted seq must not make every later batch 'late').
Batches keep their place under an *effective* seq (the device's seq plus an offset kept since its last
renumbering), so reordering, gaps and duplicates work as before within each numbering.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field, replace

from bim2rdt.bus import AccelBatch

TIME_JUMP_S = 0.05
"""A device-time jump larger than this between consecutive batches is a pause in sampling (a gap)."""
RUNS = 128
"""Runs of evenly spaced first-sample times remembered for duplicate detection (a run ends at a gap, a pause or
a change of batch length: a shift of steady batches is a handful of runs)."""
MATCH_MS = 2.0
"""Two first-sample times within this many ms are the same batch's (device times come in whole or 1/1000 ms)."""
RESTART_SEQ = 64
"""A device that restarts counts from 0: the first batch seen after it has a seq under this, even when a few
of the first were lost or overtaken on the way."""


@dataclass(slots=True)
class Gap:
    """Unsampled time in a stream: missing batches or a pause; its time is not counted as exposure."""

    start: float
    end: float
    reason: str
    missing_seqs: int = 0


@dataclass(slots=True)
class PushResult:
    """Batches now in order (with whether each starts a new segment), duplicates/late dropped, gaps."""

    pieces: list[tuple[AccelBatch, bool]] = field(default_factory=list)
    duplicates: int = 0
    late: int = 0
    gaps: list[Gap] = field(default_factory=list)
    renumbered: AccelBatch | None = None
    """The pushed batch under its effective seq, when that differs from the device's (store this one)."""
    renumberings: int = 0
    """1 when this batch started a new numbering or had its wrong seq replaced."""
    restarts: int = 0
    """1 when this batch started a new epoch: the device restarted and its clock went back."""


class StreamBuffer:
    """Ordering and gap detection of one device's batches."""

    __slots__ = ("max_reorder", "reorder_s", "next_seq", "pending", "fs", "end_time", "last_end", "offset", "_skipped",
                 "_runs", "boot", "restart_expected")

    def __init__(self, max_reorder: int = 8, reorder_s: float = 2.0):
        self.max_reorder, self.reorder_s = max_reorder, reorder_s
        self.next_seq: int | None = None
        self.pending: dict[int, AccelBatch] = {}
        self.fs = 0.0
        self.end_time: float | None = None
        """Device time just after the last sample of the current segment (None: no open segment)."""
        self.last_end: float | None = None
        """Device time just after the last sample of the last batch taken, across segments."""
        self.offset = 0
        """Added to the device's seq to place a batch (changes when the device starts a new numbering)."""
        self._skipped: deque[tuple[int, int]] = deque(maxlen=64)
        self._runs: deque[list[float]] = deque(maxlen=RUNS)
        """[first ms, last ms, count] of first-sample times taken, evenly spaced within a run."""
        self.boot: str | None = None
        """The boot id the device last announced (None: never)."""
        self.restart_expected = False
        """The device announced a new boot: its next batch whose seq goes back starts a new epoch."""

    @property
    def skipped(self) -> deque[tuple[int, int]]:
        """The seq ranges [from, to) declared missing lately (the buffer's own deque: read it, do not change it)."""
        return self._skipped

    @property
    def runs(self) -> deque[list[float]]:
        """The runs [first ms, last ms, count] of first-sample times taken (the buffer's own: read, do not change)."""
        return self._runs

    def announce_boot(self, boot: str) -> bool:
        """The device's status names its boot; True (and a restart expected) when it differs from the last one."""
        changed = self.boot is not None and boot != self.boot
        self.boot, self.restart_expected = boot, self.restart_expected or changed
        return changed

    def push(self, batch: AccelBatch, now: float) -> PushResult:
        """Accept one batch (any order); returns the batches that are now next in line."""
        result = PushResult()
        seq = batch.seq + self.offset
        if self.next_seq is not None:
            back = seq < self.next_seq or seq in self.pending
            if self._seen(batch) and not (back and self.restart_expected):
                result.duplicates = 1
                return result
            if back:
                if self._newer_than_all(batch):
                    self._flush(result)  # a new numbering: what waits came before it
                    self.offset, seq, result.renumberings = self.next_seq - batch.seq, self.next_seq, 1
                elif self._restarted(batch, seq):
                    seq = self._new_epoch(batch, result)
                else:
                    late = any(lo <= seq < hi for lo, hi in self._skipped)
                    result.late, result.duplicates = int(late), int(not late)
                    return result
                self.restart_expected = False
            else:
                if seq == self.next_seq and not self.pending:  # the usual case: the next batch, nothing waiting
                    self.restart_expected = False
                    self._take(batch if seq == batch.seq else self._renumber(batch, seq, result), result)
                    return result
                if seq > self.next_seq and self._continues(batch):
                    seq, result.renumberings = self.next_seq, 1  # a wrong number on a batch continuing the segment
                self.restart_expected = False  # the numbering went on: the announced boot did not restart it
        if seq != batch.seq:
            batch = result.renumbered = replace(batch, seq=seq)
        self.pending[seq] = batch
        self._drain(result, now)
        return result

    @staticmethod
    def _renumber(batch: AccelBatch, seq: int, result: PushResult) -> AccelBatch:
        """``batch`` under its effective seq (kept in ``result``: the store keeps this one)."""
        result.renumbered = replace(batch, seq=seq)
        return result.renumbered

    def _seen(self, batch: AccelBatch) -> bool:
        """Whether a batch starting at ``batch``'s time was taken, or waits."""
        ms = batch.device_time * 1000.0
        if self.pending and any(abs(b.device_time * 1000.0 - ms) <= MATCH_MS for b in self.pending.values()):
            return True
        for run in self._runs:  # a loop, not any(): this runs for every batch
            if _in_run(run, ms):
                return True
        return False

    def _restarted(self, batch: AccelBatch, seq: int) -> bool:
        """Whether ``batch`` (its seq gone back, its samples before what was seen) opens a new epoch: the device
        said it restarted, or its seq is low, its time was never taken and it is no late batch of a gap."""
        if self.restart_expected:
            return True
        late = any(lo <= seq < hi for lo, hi in self._skipped)
        return batch.seq < RESTART_SEQ and not late

    def _new_epoch(self, batch: AccelBatch, result: PushResult) -> int:
        """The device restarted and its clock went back: what waits came before; the device's seq 0 goes next
        (an earlier batch of the new epoch overtaken by this one still finds its place); a segment of its own."""
        self._flush(result)
        result.gaps.append(Gap(batch.device_time, batch.device_time, "device restarted"))
        if self.restart_expected:
            self._runs.clear()  # a new boot's clock: its times may repeat the old ones exactly
        self.offset, self.end_time, self.last_end = self.next_seq, None, None
        result.restarts = result.renumberings = 1
        return batch.seq + self.offset

    def _newer_than_all(self, batch: AccelBatch) -> bool:
        """Whether ``batch``'s samples start at or after every sample taken or waiting (a redelivery cannot)."""
        newest = max([b.device_time + b.duration_s for b in self.pending.values()] +
                     ([self.last_end] if self.last_end is not None else []), default=None)
        return newest is not None and batch.device_time >= newest - _tolerance(batch)

    def _continues(self, batch: AccelBatch) -> bool:
        """Whether ``batch`` starts where the open segment ends, nothing waiting in between."""
        return (self.end_time is not None and not self.pending and batch.fs == self.fs
                and abs(batch.device_time - self.end_time) <= _tolerance(batch))

    def _flush(self, result: PushResult) -> None:
        while self.pending:
            self._drain(result, float("inf"))

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
        self.end_time = self.last_end = batch.device_time + batch.duration_s
        self._remember(batch.device_time * 1000.0)
        result.pieces.append((batch, new_segment))

    def _remember(self, ms: float) -> None:
        """Add a taken first-sample time: it extends the last run when it falls where the run's spacing says."""
        run = self._runs[-1] if self._runs else None
        if run is not None:
            first, last, count = run
            step = (last - first) / (count - 1) if count > 1 else ms - last
            if step > MATCH_MS and abs(ms - last - step) <= MATCH_MS:
                run[1:] = [ms, count + 1]
                return
        self._runs.append([ms, ms, 1])

    def to_list(self) -> list:
        """[next seq, rate, segment end time, skipped seq ranges, last end, seq offset, recent first-sample times
        (ms; none since the runs), boot, restart expected, runs of first-sample times [first, last, count] (ms)]:
        compact, saved with every ingest."""
        return [self.next_seq, self.fs, self.end_time, list(self._skipped), self.last_end, self.offset, [],
                self.boot, self.restart_expected, [list(run) for run in self._runs]]

    def load(self, state: list, pending: list[AccelBatch]) -> None:
        """Restore :meth:`to_list`'s state (4- and 7-item states from before renumbering and restarts work too)
        and the waiting batches (stored under their effective seqs)."""
        self.next_seq, self.fs, self.end_time, skipped = state[:4]
        self.last_end, self.offset, recent = state[4:7] or [self.end_time, 0, []]
        self.boot, self.restart_expected, runs = state[7:] or [None, False, []]
        self._skipped.extend(tuple(pair) for pair in skipped)
        last_ms = round(self.last_end * 1000.0) if self.last_end is not None else 0
        self._runs.extend([last_ms - ago, last_ms - ago, 1] for ago in recent)  # a 7-item state's recent times
        self._runs.extend(list(run) for run in runs)
        self.pending = {b.seq: b for b in pending if self.next_seq is None or b.seq >= self.next_seq}


def _in_run(run: list[float], ms: float) -> bool:
    first, last, count = run
    if count == 1 or ms < first - MATCH_MS or ms > last + MATCH_MS:
        return abs(ms - first) <= MATCH_MS
    step = (last - first) / (count - 1)
    return abs(ms - first - round((ms - first) / step) * step) <= MATCH_MS


def _tolerance(batch: AccelBatch) -> float:
    """How far a batch's start may sit from where the stream stands and still be 'at' it: under half a batch."""
    return min(TIME_JUMP_S, 0.5 * batch.duration_s)
