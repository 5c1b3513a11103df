"""The write side of the hand-arm vibration monitor: wearable batches in, exposure and safety events out.

``MonitorIngest`` ties its parts together behind one lock:
- the in-memory engine (:mod:`~bim2rdt.safety.engine`): order, weigh, reject artefacts, track activities and
  worker-days, make events;
- sessions and corrections (:mod:`~bim2rdt.safety.sessions`): who wears which device, pseudonymously;
- persistence (:mod:`~bim2rdt.safety.persistence`, :mod:`~bim2rdt.safety.store`): every ingest is one store
  transaction (SQLite by default, PostgreSQL by ``config.store_url``), so a restart mid-shift resumes where it
  stopped, and a batch is applied at most once;
- the device clock (:mod:`~bim2rdt.safety.clock`): each stream's clock offset.
Events go to the sinks after their commit: to a plain sink at once (a sink that fails is logged and counted,
never a refused message), to a durable sink (one with an ``outbox`` name, the twin's) through the outbox in the
store, delivered by its own thread (:mod:`~bim2rdt.safety.outbox`), so the accounting never waits on it.
The bus subscriber (:mod:`~bim2rdt.safety.subscriber`) feeds this side; the read side
(:mod:`~bim2rdt.safety.queries`) reads its state; :class:`~bim2rdt.safety.monitor.HavMonitor` joins the three.
"""
from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path

from bim2rdt.bus import Event
from bim2rdt.bus import MAX_BATCH_S, AccelBatch, PayloadError, decode_status
from bim2rdt.bus import device_of
from bim2rdt.safety.config import MonitorConfig
from bim2rdt.safety.deadletters import DeadLetters, MalformedMessages
from bim2rdt.safety.engine import ExposureEngine, Outcome
from bim2rdt.safety.errors import AlreadyApplied, HavError
from bim2rdt.safety.heap import HeapSettler
from bim2rdt.safety.mounting import MountingCorrection
from bim2rdt.safety.outbox import OutboxDelivery, outbox_name
from bim2rdt.safety.persistence import MonitorJournal
from bim2rdt.safety.retention import RawRetention
from bim2rdt.safety.privacy import IdentityMap
from bim2rdt.safety.sessions import ISO_POSITIONS, Session, SessionBook
from bim2rdt.safety.sinks import EventSink, emit_each
from bim2rdt.safety.store import ExposureStore
from bim2rdt.safety.summary import merge_outcomes, push_summaries, split_summaries
from bim2rdt.safety.weighting import require_weighable_rate

__all__ = ["ISO_POSITIONS", "MalformedMessages", "MonitorConfig", "MonitorIngest", "Session"]
log = logging.getLogger("bim2rdt.safety")


class MonitorIngest:
    """Streaming ISO 5349-1 exposure for many wearables, the write side; thread-safe (one lock around each call).

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
        self.config, self.sinks, self.clock, self._owns = config, [], clock, owns
        folder = Path(data_dir) if data_dir is not None else None
        self.store = ExposureStore.for_folder(folder, config.store_url)
        self.identity = IdentityMap(folder / "private" / "identity.sqlite" if folder else None, role="monitor")
        retention = RawRetention(self.store, config.raw_recent_s, config.raw_event_margin_s, config.raw_retention_s,
                                 config.raw_max_mb * 1e6)
        self._journal = MonitorJournal(self.store, config.raw_retention_s, retention)
        self._deliveries: dict[str, OutboxDelivery] = {}
        self._sessions = SessionBook(site_secret, self.identity, self._journal.corrections())
        self._engine = ExposureEngine(config, self._sessions, clock)
        self._journal.restore(self._engine, self._owns)
        self._dead = DeadLetters({d: MalformedMessages(*row) for d, row in self.store.malformed().items()})
        self.failure: str | None = None
        """Why the monitor cannot go on (its store failed), else None: ``hav listen`` exits non-zero on it."""
        self._heap = HeapSettler(config.settle_heap)
        self._lock = threading.RLock()
        for sink in sinks:
            self.add_sink(sink)

    def add_sink(self, sink: EventSink) -> None:
        """Send the events of every later commit to ``sink``: at once, or, for a sink with an ``outbox`` name
        (the twin's), through the store's outbox: queued in each commit's transaction, delivered in order by a
        background thread that retries every ``config.outbox_retry_s`` while the sink fails, none lost or
        doubled; events queued for that name by an earlier run are delivered too.

        Args:
            sink: Anything with ``emit(event)``; an ``outbox`` attribute names a durable one.

        Raises:
            HavError: The monitor already has a durable sink of that name.
        """
        name = outbox_name(sink)
        if name is None:
            self.sinks.append(sink)
            return
        with self._lock:
            if name in self._deliveries:
                raise HavError(f"the monitor already has a durable sink named {name!r}")
            self._deliveries[name] = OutboxDelivery(self.store, name, sink, self.config.outbox_retry_s).start()
            self._journal.outbox.append(name)

    def drain_outbox(self, timeout_s: float) -> bool:
        """Wait for every durable sink to take what is queued.

        Args:
            timeout_s: How long to wait for each sink, seconds.

        Returns:
            True when all did.
        """
        return all([d.drain(timeout_s) for d in self._deliveries.values()])

    # --- sessions and corrections ------------------------------------------------------------------------
    def start_session(self, device: str, worker: str, tool: str = "unknown", position: str = "handle",
                      zone: str | None = None, hand: str = "") -> str:
        """Bind a device to a worker (stored as a pseudonym), a tool, a body position, a work zone and a hand.

        Args:
            device: The wearable's device id.
            worker: The worker's real id; only its pseudonym is stored with exposure.
            tool: The tool the worker uses.
            position: Where the wearable sits (an ISO 5349 position, or an estimate elsewhere).
            zone: The work zone (a BIM zone name or GlobalId), if known.
            hand: "left" or "right" when known.

        Returns:
            The worker's pseudonym (the subject of the session's events).

        Raises:
            HavError: An empty worker id.
        """
        with self._lock:
            session = self._sessions.claim(worker, tool, position, zone, hand)
            outcome = self._engine.rebind(device, session)
            if outcome.streams:
                self._commit(outcome, sessions={device: session})
            return session.subject

    def end_session(self, device: str, when: float | None = None) -> list[Event]:
        """The device went offline or the session is over: flush its stream and end its activity at ``when``
        (default: the device time of its last sample, not when the news reached us).

        Args:
            device: The wearable's device id.
            when: When the activity ended, UTC seconds; None takes its last sample's time.

        Returns:
            The events the end caused (and emitted).
        """
        with self._lock:
            outcome = self._engine.close(device, when)
            if outcome.streams:
                self._commit(outcome)
            return outcome.events

    def add_correction(self, correction: MountingCorrection) -> None:
        """Use a mounting correction for every stream of its subject at its position (persisted).

        Args:
            correction: Band gains of one subject at one wearable position.
        """
        with self._lock:
            self._sessions.add_correction(correction)
            self._journal.save_correction(correction)

    # --- ingest ------------------------------------------------------------------------------------------
    def ingest(self, batch: AccelBatch) -> list[Event]:
        """Take one batch (see :meth:`ingest_many`).

        Args:
            batch: Accelerations (n,3) in m/s^2 from one device.

        Returns:
            The events it caused (and emitted).
        """
        return self.ingest_many([batch])

    def ingest_many(self, batches: Iterable[AccelBatch], now: float | None = None) -> list[Event]:
        """Take batches (and on-device summaries, :mod:`~bim2rdt.safety.summary`) from any devices in any order;
        returns (and emits) the events they caused. HavError,
        before any state changes, if a batch's rate is too low to weigh or it holds more than ``MAX_BATCH_S``
        of samples (as the bus refuses: the store finds a raw window's batches within that reach).

        Args:
            batches: Accel batches ((n,3) m/s^2) and on-device summaries, from any devices in any order.
            now: The receive time, UTC seconds; None reads the monitor's clock.

        Returns:
            The events they caused (and emitted).

        Raises:
            HavError: A batch's rate is too low to weigh, or it holds more than ``MAX_BATCH_S`` of samples.
        """
        batches, summaries = split_summaries(batches)  # on-device summaries (safety.summary) ride along
        for batch in batches:
            require_weighable_rate(batch.fs)
            if not batch.duration_s <= MAX_BATCH_S:
                raise HavError(f"batch {batch.seq} of {batch.device} holds {batch.duration_s:g} s of samples: at "
                               f"most {MAX_BATCH_S:g} s")
        with self._lock, self._heap.round():  # the collector's young passes after the round, not in it
            now = self.clock() if now is None else now
            outcome = self._push(batches, summaries, now)
            try:
                self._commit(outcome, now)
            except AlreadyApplied:  # memory was behind the store: reload it; what was applied is now a duplicate
                log.warning("a batch was already applied to the store; reloading the engine from it")
                self._reload()
                outcome = self._push(batches, summaries, now)
                self._commit(outcome, now)
            return outcome.events

    def _push(self, batches: list[AccelBatch], summaries: list, now: float) -> Outcome:
        outcome = self._engine.push(batches, now)
        return merge_outcomes(outcome, push_summaries(self._engine, summaries, now)) if summaries else outcome

    def on_status(self, topic: str, payload: bytes) -> list[Event]:
        """A wearable's retained status: online with a worker starts a session, offline ends it; a malformed
        one is dead-lettered.

        Args:
            topic: The message's topic, ``site/{site}/wearable/{device}/status``.
            payload: The status message.

        Returns:
            The events an ended session caused (and emitted).
        """
        device = device_of(topic) or "?"
        try:
            status = decode_status(payload)
        except PayloadError as error:
            self.refuse(device, str(error), self.clock())
            return []
        if status.online and status.boot is not None:  # a device coming online says which boot it is in
            self.announce_boot(device, status.boot)
        if status.online and status.worker:
            self.start_session(device, status.worker, status.tool, status.position, status.zone, status.hand)
            return []
        return self.end_session(device) if not status.online else []

    def announce_boot(self, device: str, boot: str) -> bool:
        """The device names its boot (status ``boot``); True when it differs from the last one: it restarted, and
        its next batch whose seq goes back starts a new epoch that counts (persisted).

        Args:
            device: The wearable's device id.
            boot: The boot's id as the device sends it.

        Returns:
            True when the device restarted since its last announced boot.
        """
        with self._lock:
            stream = self._engine.stream(device)
            previous = stream.buffer.boot
            changed = stream.buffer.announce_boot(boot)
            if boot != previous:
                self._commit(Outcome([], {device: stream}, []))
            return changed

    def expire(self, now: float) -> list[Event]:
        """Declare overdue gaps on streams whose missing batches never came.

        Args:
            now: UTC seconds.

        Returns:
            The events caused (and emitted).
        """
        with self._lock:
            outcome = self._engine.expire(now)
            if outcome.streams:
                self._commit(outcome, now)
            return outcome.events

    def count(self, name: str, amount: float = 1) -> None:
        """Add to one of the monitor's counters (:attr:`~bim2rdt.safety.queries.MonitorQueries.stats`).

        Args:
            name: The counter.
            amount: What to add.
        """
        with self._lock:
            self._engine.count(name, amount)

    # --- refused messages and failures --------------------------------------------------------------------
    def refuse(self, device: str, reason: str, received: float, kind: str = "malformed") -> None:
        """Dead-letter a message from ``device``: counted (``stats[kind]`` and per device), logged, persisted
        with the next commit.

        Args:
            device: The device id the message came from ("?" when unknown).
            reason: Why it was refused, one line.
            received: When it arrived, UTC seconds.
            kind: The counter it is counted under.
        """
        with self._lock:
            self._engine.count(kind)
            self._dead.record(device, reason, received)

    def save_dead_letters(self) -> None:
        """Persist the refused-message counts that changed since the last commit."""
        with self._lock:
            rows = self._dead.take_dirty()
            if rows:
                with self.store.transaction():
                    self.store.save_malformed(rows)

    def fail(self, reason: str) -> None:
        """Record that the monitor cannot go on (see :attr:`failure`); the first reason is kept.

        Args:
            reason: Why, one line.
        """
        self.failure = self.failure or reason

    def recover(self, batches: list[AccelBatch], reason: str) -> None:
        """The engine failed on ``batches``: dead-letter them and reload the engine from the store, so memory
        holds exactly what was committed.

        Args:
            batches: The batches the engine failed on.
            reason: Why, one line.
        """
        with self._lock:
            for batch in batches:
                self.refuse(batch.device, reason, self.clock())
            self._reload()

    def refresh(self) -> None:
        """Reload days, streams, sessions and refused-message counts from the store: for a reader (``serve --nats``)
        of a store that other processes (the partitions' monitors) write; such a reader ingests nothing."""
        with self._lock:
            self._reload()
            self._dead = DeadLetters({d: MalformedMessages(*row) for d, row in self.store.malformed().items()})

    def _reload(self) -> None:
        """Rebuild the engine from the store (counts and timeline carried over)."""
        stats, timeline = self._engine.stats, self._engine.timeline
        self._engine = ExposureEngine(self.config, self._sessions, self.clock)
        self._engine.stats.update(stats)
        self._engine.timeline.extend(timeline)
        self._journal.restore(self._engine, self._owns)

    def close(self) -> None:
        """Save the refused-message counts, give the durable sinks up to ``config.outbox_drain_s`` to take what is
        queued (the rest waits in the store for the next start), then close the store and the identity map, and give
        the settled heap back to the collector (:class:`~bim2rdt.safety.heap.HeapSettler`)."""
        with self._lock:
            self.save_dead_letters()
        if not self.drain_outbox(self.config.outbox_drain_s):
            log.warning("closing with events still queued for %s: delivered at the next start",
                        ", ".join(name for name, d in self._deliveries.items() if d.pending()))
        for delivery in self._deliveries.values():
            delivery.stop()
        with self._lock:
            self.store.close()
            self.identity.close()
            self._heap.release()

    # --- internals ---------------------------------------------------------------------------------------
    def _commit(self, outcome: Outcome, now: float | None = None, sessions: dict[str, Session] | None = None) -> None:
        """Persist what a call changed in one transaction (the events queued for the durable sinks in it), then
        hand its events to the plain sinks (a sink that fails is logged and counted in ``stats["sink_errors"]``,
        see :func:`~bim2rdt.safety.sinks.emit_each`) and wake the durable sinks' deliveries; settle the heap when the
        streams have doubled (:class:`~bim2rdt.safety.heap.HeapSettler`)."""
        now = self.clock() if now is None else now
        self._journal.commit(self._engine, outcome.accepted, outcome.streams.values(), outcome.events, now, sessions,
                             self._dead.take_dirty())
        failed = emit_each(self.sinks, outcome.events)
        if failed:
            self._engine.count("sink_errors", failed)
        if outcome.events:
            for delivery in self._deliveries.values():
                delivery.wake()
        self._heap.grown(len(self._engine.streams))  # a grown fleet leaves the collector's full passes
