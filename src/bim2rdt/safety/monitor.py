"""The streaming hand-arm vibration monitor: wearable batches in, exposure and safety events out.

``HavMonitor`` joins three parts, each in its own module, that import one another in one direction only:
- the write side (:mod:`~bim2rdt.safety.ingest`): sessions, ingest, refused messages, failure, the store;
- the bus subscriber (:mod:`~bim2rdt.safety.subscriber`): accel and status topics, group commits into the write
  side;
- the read side (:mod:`~bim2rdt.safety.queries`, :attr:`HavMonitor.queries`): what the server and the CLI show.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from bim2rdt.bus import Event
from bim2rdt.safety.config import MonitorConfig
from bim2rdt.safety.deadletters import MalformedMessages
from bim2rdt.safety.ingest import MonitorIngest
from bim2rdt.safety.queries import MonitorQueries
from bim2rdt.safety.sessions import ISO_POSITIONS, Session
from bim2rdt.safety.sinks import EventSink
from bim2rdt.safety.subscriber import BusSubscriber

if TYPE_CHECKING:
    from bim2rdt.bus import LocalBus
    from bim2rdt.bus import MqttBus
    from bim2rdt.bus import NatsBus

__all__ = ["ISO_POSITIONS", "HavMonitor", "MalformedMessages", "MonitorConfig", "Session"]


class HavMonitor(MonitorIngest):
    """Streaming ISO 5349-1 exposure for many wearables: the write side fed from a bus, its reads in
    :attr:`queries`; thread-safe (one lock around each call).

    State lives under ``data_dir`` (``hav.sqlite``, ``private/identity.sqlite``), or in the database at
    ``config.store_url`` (the identity map stays under ``data_dir``).

    Args:
        data_dir: The monitor's folder; None (and no ``config.store_url``) keeps everything in memory, for a
            throw-away monitor that must write nothing (``hav analyze``).
        site_secret: The key of the worker pseudonyms.
        sinks: Where events go; those with an ``outbox`` name are durable (see :meth:`add_sink`).
        config: Thresholds, group commit, retention and the store's URL.
        clock: The wall clock, UTC seconds.
        owns: ``owns(device)`` says which devices this monitor serves when several share one store (a partition
            of the NATS path); only their streams are restored. None serves every device.
    """

    def __init__(self, data_dir: Path | None, site_secret: str, sinks: Sequence[EventSink] = (),
                 config: MonitorConfig = MonitorConfig(), clock: Callable[[], float] = time.time,
                 owns: Callable[[str], bool] | None = None):
        super().__init__(data_dir, site_secret, sinks, config, clock, owns)
        self._subscriber = BusSubscriber(self, config.commit_batches, config.commit_delay_s, self._lock)
        self.queries = MonitorQueries(self.store, self._lock, lambda: self._engine, lambda: self._dead,
                                      self._deliveries, self.clock)
        """The read side: exposure, sessions, stream status, refused messages, and the store's reads."""

    def ingest_payload(self, topic: str, payload: bytes, received: float | None = None) -> list[Event]:
        """An MQTT accel message, ingested now; ignored (and counted) if malformed, too slowly sampled to weigh,
        or its device id is not the topic's. Never raises on bad input.

        Args:
            topic: The message's topic, ``site/{site}/wearable/{device}/accel``.
            payload: The message.
            received: When it arrived, UTC seconds; None reads the monitor's clock.

        Returns:
            The events it caused (and emitted); none for a refused message.
        """
        with self._lock:
            batch = self._subscriber.accept(topic, payload, self.clock() if received is None else received)
            return self.ingest_many([batch]) if batch is not None else []

    def tick(self, now: float | None = None) -> list[Event]:
        """Commit a bus group that waited long enough; declare overdue gaps on streams whose missing batches
        never came.

        Args:
            now: UTC seconds; None reads the monitor's clock.

        Returns:
            The events caused (and emitted).
        """
        with self._lock:
            now = self.clock() if now is None else now
            events = self._subscriber.tick(now)
            return events + self.expire(now)

    def attach(self, bus: LocalBus | MqttBus | NatsBus) -> None:
        """Subscribe to every wearable's accel and status topics of the configured site (attach before
        connecting an MQTT bus with a persistent session, so queued messages find their handler).

        Args:
            bus: The site event bus.
        """
        self._subscriber.attach(bus)

    def flush(self) -> list[Event]:
        """Commit the bus messages waiting for their group commit now.

        Returns:
            The events they caused (and emitted).
        """
        return self._subscriber.flush()

    def close(self) -> None:
        """Commit what waits for a group commit, give the durable sinks up to ``config.outbox_drain_s`` to take
        what is queued (the rest waits in the store for the next start), then close the store and the identity
        map."""
        self._subscriber.stop()
        with self._lock:
            self.flush()
        super().close()
