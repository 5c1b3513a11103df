"""The monitor on the site bus: wearable accel and status messages in, group commits out.

Accel messages are decoded and checked, then held until ``commit_batches`` of them are waiting or the oldest has
waited ``commit_delay_s``; then they are ingested together: one store transaction and one filtering pass per
stream instead of one per message. A background thread commits a group that waited ``commit_delay_s`` when no
further message comes. A status message (a session starts or ends) first commits what is waiting, so every
batch counts under the session it was sent in.

No message raises out of a handler (it would stop an MQTT client's network thread): one that fails its checks
is dead-lettered (:mod:`~bim2rdt.safety.deadletters`: counted per device, logged, acknowledged, never
redelivered). If the engine itself fails on a group, the group is dead-lettered and the engine reloaded from
the store, so memory never disagrees with what was committed. A store that cannot be written (disk full, I/O
error) is a failure the monitor reports (``HavMonitor.failure``): ``hav listen`` then exits non-zero, the
messages stay unacknowledged and the broker keeps them for the next start.

Loss window: over MQTT with manual acknowledgement (``MqttBus(manual_ack=True)``) a message is acknowledged
only after its commit, so a crash loses nothing: the broker redelivers what was not acknowledged and the
monitor drops what it had already committed as duplicates. On a bus that cannot redeliver (the in-process
``LocalBus``), a crash loses at most the batches waiting for their commit: ``commit_batches`` messages, received
within the last ``commit_delay_s`` seconds.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING

from bim2rdt.bus import Event
from bim2rdt.bus import AccelBatch, PayloadError, decode_accel
from bim2rdt.bus import DeviceSummary, decode_summary
from bim2rdt.bus import device_of, wearable_pattern
from bim2rdt.safety.errors import HavError, StoreError
from bim2rdt.safety.weighting import require_weighable_rate

if TYPE_CHECKING:
    from bim2rdt.safety.ingest import MonitorIngest

Ack = Callable[[], None]
log = logging.getLogger("bim2rdt.safety")


class BusSubscriber:
    """Feeds a monitor's write side (:class:`~bim2rdt.safety.ingest.MonitorIngest`) from a bus in group commits
    (see the module docstring)."""

    def __init__(self, monitor: MonitorIngest, commit_batches: int, commit_delay_s: float,
                 lock: threading.RLock):
        self.monitor, self.commit_batches, self.commit_delay_s = monitor, commit_batches, commit_delay_s
        self._waiting: list[AccelBatch] = []
        self._acks: list[Ack] = []
        self._oldest: float | None = None
        self._lock = lock  # the monitor's: one lock, so a bus thread and a tick never wait on each other
        self._stop = threading.Event()
        self._flusher: threading.Thread | None = None

    def attach(self, bus) -> None:
        """Subscribe to the site's wearable status and accel topics (status first: a retained status tells
        who wears a device before its samples arrive)."""
        site = self.monitor.config.site
        bus.subscribe(wearable_pattern(site, "status"), self.on_status, qos=1, manual_ack=True)
        bus.subscribe(wearable_pattern(site, "accel"), self.on_accel, qos=1, manual_ack=True)
        bus.subscribe(wearable_pattern(site, "summary"), self.on_summary, qos=1, manual_ack=True)
        if self._flusher is None and self.commit_delay_s > 0:
            self._flusher = threading.Thread(target=self._flush_when_due, name="hav-group-commit", daemon=True)
            self._flusher.start()

    def stop(self) -> None:
        """Stop the background commits (the monitor then commits what waits)."""
        self._stop.set()
        if self._flusher is not None and self._flusher is not threading.current_thread():
            self._flusher.join()

    def oversized(self, device: str, payload: bytes, received: float) -> bool:
        """True (and the message dead-lettered) when an accel ``payload`` is longer than any wearable sends: it is
        refused before decoding, so a valid header declaring millions of samples costs nothing (statuses and
        summaries have their own, smaller bounds where they are decoded)."""
        limit = self.monitor.config.max_message_bytes
        if len(payload) <= limit:
            return False
        self.monitor.refuse(device, f"message of {len(payload)} bytes: over the {limit}-byte bound of a wearable "
                            f"message", received)
        return True

    def accept(self, topic: str, payload: bytes, received: float) -> AccelBatch | None:
        """The message's batch, stamped ``received``; None (dead-lettered) if it is malformed, too slowly sampled
        to weigh, or its device id is not the topic's."""
        device = device_of(topic) or "?"
        if self.oversized(device, payload, received):
            return None
        try:
            batch = decode_accel(payload)
            require_weighable_rate(batch.fs)
        except (PayloadError, HavError) as error:
            self.monitor.refuse(device, str(error), received)
            return None
        if batch.device != device:
            self.monitor.refuse(device, f"payload device id {batch.device!r} is not the topic's", received,
                                kind="mismatched")
            return None
        return batch.received_at(received)

    def accept_summary(self, topic: str, payload: bytes, received: float) -> DeviceSummary | None:
        """The on-device summary, stamped ``received``; None (dead-lettered) if malformed or not the topic's device."""
        device = device_of(topic) or "?"
        try:
            summary = decode_summary(payload)
        except PayloadError as error:
            self.monitor.refuse(device, str(error), received)
            return None
        if summary.device != device:
            self.monitor.refuse(device, f"summary device id {summary.device!r} is not the topic's", received,
                                kind="mismatched")
            return None
        return summary.received_at(received)

    def on_summary(self, topic: str, payload: bytes, ack: Ack | None = None) -> list[Event]:
        """Hold a good on-device summary for the next group commit (with the batches)."""
        return self.on_accel(topic, payload, ack, accept=self.accept_summary)

    def on_accel(self, topic: str, payload: bytes, ack: Ack | None = None, accept=None) -> list[Event]:
        """Hold a good batch for the next group commit; commit if the group is full or old enough."""
        with self._lock:
            now = self.monitor.clock()
            batch = (accept or self.accept)(topic, payload, now)
            if batch is None and not self._waiting:
                _call(ack)  # dead-lettered: acknowledged, never redelivered
                return []
            if batch is not None:
                self._waiting.append(batch)
                self._oldest = now if self._oldest is None else self._oldest
            if ack is not None:
                self._acks.append(ack)
            return self.flush(now) if self._due(now) else []

    def on_status(self, topic: str, payload: bytes, ack: Ack | None = None) -> list[Event]:
        """A wearable's retained status, after committing what is waiting."""
        with self._lock:
            events = self.flush()
            events += self.monitor.on_status(topic, payload)
            _call(ack)
            return events

    def tick(self, now: float) -> list[Event]:
        """Commit the waiting group if its oldest batch has waited ``commit_delay_s``."""
        with self._lock:
            return self.flush(now) if self._oldest is not None and now - self._oldest >= self.commit_delay_s else []

    def flush(self, now: float | None = None) -> list[Event]:
        """Ingest and commit every waiting batch, then acknowledge their messages (in order)."""
        with self._lock:
            batches, acks = self._waiting, self._acks
            self._waiting, self._acks, self._oldest = [], [], None
            events = self._ingest(batches, now) if batches else []
            for ack in acks:
                ack()
            return events

    def _ingest(self, batches: list[AccelBatch], now: float | None) -> list[Event]:
        try:
            return self.monitor.ingest_many(batches, now=now)
        except (StoreError, OSError) as error:  # the store failed: keep the messages unacknowledged
            self.monitor.fail(f"the exposure store failed: {error}")  # unacknowledged: redelivered after a restart
            raise
        except Exception as error:  # an engine failure on input that passed its checks: never stop for it
            log.exception("the engine failed on a group of %d batches; dead-lettered", len(batches))
            self.monitor.recover(batches, f"internal error: {type(error).__name__}: {error}")
            return []

    def _due(self, now: float) -> bool:
        return max(len(self._waiting), len(self._acks)) >= self.commit_batches or (
            self._oldest is not None and now - self._oldest >= self.commit_delay_s)

    def _flush_when_due(self) -> None:
        while not self._stop.wait(max(self.commit_delay_s / 2, 0.01)):
            try:
                self.tick(self.monitor.clock())
                self.monitor.save_dead_letters()
            except Exception:  # reported through HavMonitor.failure; this thread must not die silently
                log.exception("background commit failed")


def _call(ack: Ack | None) -> None:
    if ack is not None:
        ack()
