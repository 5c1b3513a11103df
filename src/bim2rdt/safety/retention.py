"""How long raw accelerometer batches stay in the exposure store: a recent window, windows around events, an age
and a size bound.

Exposure never needs them once framed (the days, activities and events hold the figures); they are kept for
people: the dashboard's live raw view (the newest seconds of a device) and the safety officer's look at what
happened around an event. So, on every commit:

- **recent**: every batch within ``raw_recent_s`` of its device's newest sample (device time, so a replay at
  speed keeps the same seconds as a live device) is kept;
- **around events**: a batch that falls out of the recent window is kept if it lies within ``raw_event_margin_s``
  of an event of :data:`KEPT_KINDS` (activity start and end, EAV/ELV reached, an artefact) on its device, and
  compressed (zlib over byte planes, ~0.6 of its size); any other is deleted;
- **age**: any batch received more than ``raw_retention_s`` ago is deleted, kept or not;
- **size**: when the raw samples exceed ``raw_max_mb``, the oldest received are deleted first.
A batch still waiting for a predecessor is never deleted (a restart needs it). ``raw_retention_s`` 0 keeps only
those.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Callable, Iterable

from bim2rdt.bus import Event
from bim2rdt.safety.activity import ACTIVITY_ENDED, ACTIVITY_STARTED, ARTEFACT, EAV_REACHED, ELV_REACHED
from bim2rdt.safety.store import ExposureStore

KEPT_KINDS = (ACTIVITY_STARTED, ACTIVITY_ENDED, EAV_REACHED, ELV_REACHED, ARTEFACT)
"""Events whose surrounding raw samples are kept: where a person checks what the sensor saw."""
SORT_EVERY_S = 5.0
"""A device's batches are sorted out of the recent window in steps of this many seconds of its samples: deletes of
neighbouring rows in one commit share their b-tree and free-list pages (fewer page writes, fewer reads when the
WAL is checkpointed)."""
SIZE_CHECK_EVERY_S = 10.0
"""Seconds (monitor clock) between checks of the raw samples' total size."""


class RawRetention:
    """Applies the rule of the module docstring to one store, inside the monitor's commits."""

    def __init__(self, store: ExposureStore, recent_s: float, event_margin_s: float, retention_s: float,
                 max_bytes: float):
        self.store, self.recent_s, self.event_margin_s = store, recent_s, event_margin_s
        self.retention_s, self.max_bytes = retention_s, max_bytes
        self._windows: dict[str, list[tuple[float, float, float]]] = {}
        """device -> (start, end device time, keep until (receive clock)) of the windows around its events."""
        self._handled: dict[str, float] = {}
        """device -> device time below which its unkept batches were already deleted or kept."""
        self._size_checked_at = -float("inf")
        self._bytes: int | None = None
        """Bytes of raw samples in the store, kept up to date from what is written and deleted (counted once, at
        the first size check: a scan reads every raw page)."""

    def saved(self, size: int) -> None:
        """``size`` bytes of raw samples were written."""
        if self._bytes is not None:
            self._bytes += size

    def restore(self) -> None:
        """Load the event windows saved before a restart."""
        for device, start, end, until in self.store.keep_windows():
            self._windows.setdefault(device, []).append((start, end, until))

    def note_events(self, events: Iterable[Event], offsets: dict[str, float], now: float) -> None:
        """Keep the raw samples around ``events`` of :data:`KEPT_KINDS`; ``offsets`` maps a device to the seconds
        its event times were moved from its own clock (placed on the receive clock), else 0."""
        rows = []
        for event in events:
            if event.kind in KEPT_KINDS and event.source:
                at = event.time - offsets.get(event.source, 0.0)
                rows.append((event.source, at - self.event_margin_s, at + self.event_margin_s, now + self.retention_s))
        for device, start, end, until in rows:
            self._windows.setdefault(device, []).append((start, end, until))
        self.store.add_keep_windows(rows)

    def prune(self, streams: Iterable[tuple[str, int, float | None]], now: float,
              next_seq_of: Callable[[str], int | None]) -> None:
        """Apply the recent and event rules to each (device, next seq, newest sample end (device time)) stream
        touched, and now and then the size bound (``next_seq_of(device)``: its first batch not yet processed)."""
        for device, next_seq, newest in streams:
            if newest is not None and self._due(device, newest - self.recent_s):
                self._sort_out(device, next_seq, newest - self.recent_s)
        if now - self._size_checked_at >= SIZE_CHECK_EVERY_S:
            self._size_checked_at = now
            self.store.drop_keep_windows(now)
            self._windows = {d: [w for w in ws if w[2] > now] for d, ws in self._windows.items()}
            self._bound_size(next_seq_of)

    def _due(self, device: str, cut: float) -> bool:
        """Whether ``cut`` crossed a step of the device's grid since its last sorting out: steps of
        ``SORT_EVERY_S`` shifted by a phase of its own (:func:`sort_phase`), so devices whose clocks run in step (a
        fleet switched on together) do not all sort out in the same commit."""
        handled = self._handled.get(device)
        if handled is None:
            return True
        phase = sort_phase(device)
        return math.floor((cut - phase) / SORT_EVERY_S) > math.floor((handled - phase) / SORT_EVERY_S)

    def _sort_out(self, device: str, next_seq: int, cut: float) -> None:
        """Keep (and compress) or delete the device's processed batches that fell out of the recent window."""
        rows = self.store.unkept_between(device, self._handled.get(device, -float("inf")), cut)
        windows = self._windows.get(device, [])
        keep, drop, waiting, freed = [], [], [], 0
        for seq, start, end, size in rows:
            if seq >= next_seq:
                waiting.append(start)
            elif any(start < w_end and end > w_start for w_start, w_end, _ in windows):
                keep.append((device, seq))
            else:
                drop.append((device, seq))
                freed += size
        freed += self.store.keep_raw(keep, compress=True)
        self.store.delete_raw(drop)
        if self._bytes is not None:
            self._bytes -= freed
        self._handled[device] = min([cut, *waiting])

    def _bound_size(self, next_seq_of: Callable[[str], int | None]) -> None:
        """Delete the oldest received processed batches while the raw samples exceed the size bound."""
        if self._bytes is None:
            self._bytes = self.store.raw_bytes()
        excess = self._bytes - self.max_bytes
        if excess <= 0:
            return
        gone = []
        for device, seq, size in self.store.oldest_raw():
            if excess <= 0:
                break
            processed = next_seq_of(device)
            if processed is not None and seq < processed:
                gone.append((device, seq))
                excess -= size
                self._bytes -= size
        self.store.delete_raw(gone)


def sort_phase(device: str) -> float:
    """The device's offset (seconds, in [0, ``SORT_EVERY_S``)) of its sorting-out steps: fixed per device name."""
    return zlib.crc32(device.encode()) % 1000 / 1000 * SORT_EVERY_S
