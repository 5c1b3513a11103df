"""The read side of the monitor's store, for the server and the CLI: events and raw sensor windows, read on the
store's pooled connections (never the monitor's writer, never its lock; on SQLite, WAL lets them read while the
monitor writes). Exposure figures that live in the monitor's memory (days, sessions, stream status) stay on
:class:`~bim2rdt.safety.monitor.HavMonitor`'s own reads."""

from __future__ import annotations

from bim2rdt.bus import Event
from bim2rdt.bus import AccelBatch
from bim2rdt.safety.store import ExposureStore


class MonitorReads:
    """What a reader may ask of a monitor's store."""

    def __init__(self, store: ExposureStore):
        self._store = store

    def events(self, kind: str | None = None, since: float | None = None) -> list[Event]:
        """The monitor's events in commit order, of ``kind`` (default all), that happened after ``since`` (UTC s)."""
        return self._store.events(kind, since)

    def raw_window(self, device: str, start: float, end: float) -> list[AccelBatch]:
        """The device's kept raw batches with samples in device time [start, end), in seq order."""
        return self._store.raw_window(device, start, end)

    def last_sample_time(self, device: str) -> float | None:
        """The device time just after the device's newest kept raw sample (None when none is kept)."""
        last = self._store.last_raw(device)
        return last.device_time + last.duration_s if last is not None else None

    def size_bytes(self) -> int:
        """Bytes the store takes on disk."""
        return self._store.size_bytes()
