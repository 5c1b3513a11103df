"""The read side of the hand-arm vibration monitor, for the server and the CLI: the exposure figures the write side
(:mod:`~bim2rdt.safety.ingest`) holds in memory (worker-days, sessions, stream status, activities, refused
messages, counters), read under its lock, and the store's reads (:attr:`MonitorQueries.reads`: events and raw
windows, read without it). It changes nothing: what it shows is what the write side last committed."""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping

from bim2rdt.safety.activity import ActivityState, DayState, utc_day
from bim2rdt.safety.deadletters import DeadLetters, MalformedMessages
from bim2rdt.safety.engine import ExposureEngine
from bim2rdt.safety.outbox import OutboxDelivery
from bim2rdt.safety.reads import MonitorReads
from bim2rdt.safety.sessions import Session
from bim2rdt.safety.store import ExposureStore
from bim2rdt.safety.summary import stream_kind

__all__ = ["MonitorQueries"]


class MonitorQueries:
    """What a reader may ask of a monitor. ``engine`` and ``dead_letters`` return the write side's current ones
    (a reload replaces them); every in-memory read holds ``lock``, the write side's.

    Args:
        store: The write side's store, for :attr:`reads`.
        lock: The write side's lock, held by every in-memory read.
        engine: Returns the write side's current exposure engine (days, streams, counters, timeline).
        dead_letters: Returns the write side's current refused-message counts.
        deliveries: The write side's durable-sink deliveries, by sink name.
        clock: The wall clock, UTC seconds (which day is today).
    """

    def __init__(self, store: ExposureStore, lock: threading.RLock, engine: Callable[[], ExposureEngine],
                 dead_letters: Callable[[], DeadLetters], deliveries: Mapping[str, OutboxDelivery],
                 clock: Callable[[], float]):
        self.store, self.clock = store, clock
        self._lock, self._current_engine, self._current_dead, self._deliveries = lock, engine, dead_letters, deliveries

    @property
    def _engine(self) -> ExposureEngine:
        return self._current_engine()

    @property
    def _dead(self) -> DeadLetters:
        return self._current_dead()

    @property
    def reads(self) -> MonitorReads:
        """The read side of the store (events, raw windows) for the server and the CLI: reads never take the
        monitor's lock."""
        return MonitorReads(self.store)

    def outbox_status(self) -> dict[str, dict]:
        """How the durable sinks' deliveries stand.

        Returns:
            {sink name: {"pending", "delivered", "failures", "last_error"}}: events waiting, delivered by this
                process, failed deliveries, the last error.
        """
        return {name: {"pending": d.pending(), "delivered": d.delivered, "failures": d.failures,
                       "last_error": d.last_error} for name, d in self._deliveries.items()}

    @property
    def stats(self) -> dict[str, float]:
        """Counts over the monitor's life: duplicates, late, gaps, malformed, mismatched."""
        return self._engine.stats

    @property
    def timeline(self) -> list[tuple[float, str, float]]:
        """(device time, subject, A(8)) after every counted block, when ``config.keep_timeline``."""
        return self._engine.timeline

    def malformed_messages(self) -> dict[str, MalformedMessages]:
        """Refused (dead-lettered) messages per device since the store was created: count, last reason, when
        the last one arrived. For the dashboard: a device sending garbage shows here, never as exposure.

        Returns:
            {device: its refused messages}, by device id.
        """
        with self._lock:
            return {device: MalformedMessages(m.count, m.last_reason, m.last_received)
                    for device, m in sorted(self._dead.by_device.items())}

    def day(self, subject: str, day: str | None = None) -> DayState:
        """A worker-day's exposure.

        Args:
            subject: The worker's pseudonym.
            day: The UTC day, 'YYYY-MM-DD'; None is today.

        Returns:
            Its weighted energy (m^2/s^3) and trigger time (s) per hand, and when the EAV and ELV were reached
                (UTC seconds); empty for a day without exposure.
        """
        with self._lock:
            return self._engine.days.get((subject, day or utc_day(self.clock())), DayState())

    def days_of(self, subject: str) -> list[str]:
        """The days with exposure on record for a worker.

        Args:
            subject: The worker's pseudonym.

        Returns:
            UTC days, 'YYYY-MM-DD', oldest first.
        """
        with self._lock:
            return sorted(day for who, day in self._engine.days if who == subject)

    def devices(self) -> list[str]:
        """Every device the monitor has seen (or restored).

        Returns:
            Their device ids.
        """
        with self._lock:
            return list(self._engine.streams)

    def session(self, device: str) -> Session | None:
        """Who wears a device now.

        Args:
            device: The wearable's device id.

        Returns:
            Its session (pseudonym, tool, position, zone, hand), or None for a device never seen.
        """
        with self._lock:
            stream = self._engine.streams.get(device)
            return stream.session if stream else None

    def stream_status(self, device: str) -> dict | None:
        """Where a device's stream stands: next expected seq, batches waiting, counters, clock offset (s), the
        time base its events and days are on ('receive' for a device without wall time, else 'device') and what
        the device sends ('stream': 'raw' batches, on-device 'summary' seconds, 'mixed' or 'none').

        Args:
            device: The wearable's device id.

        Returns:
            The stream's state, or None for a device never seen.
        """
        with self._lock:
            stream = self._engine.streams.get(device)
            if stream is None:
                return None
            return {"next_seq": stream.buffer.next_seq, "waiting": sorted(stream.buffer.pending),
                    "clock_offset_s": stream.clock.offset_s, "time_base": stream.time_base,
                    "stream": stream_kind(stream.counters), **stream.counters}

    def activity(self, device: str) -> ActivityState | None:
        """The activity running on a device's stream.

        Args:
            device: The wearable's device id.

        Returns:
            Its state (``id`` None when idle), or None for a device never seen.
        """
        with self._lock:
            stream = self._engine.streams.get(device)
            return stream.tracker.state if stream else None
