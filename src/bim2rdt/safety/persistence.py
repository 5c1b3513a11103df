"""The monitor's persistence: each ingest's changes in one store transaction, and the engine restored from them.

One commit holds the raw batches (all while retained, else only those still waiting for a predecessor), the keys
of the batches it applies (the ledger: a batch is applied at most once), the touched streams' ordering, filter,
activity and clock state, the touched worker-days, the events (queued in the outbox for each durable sink) and
the activities they start or end. A restart therefore resumes exactly where the last commit left off: batches
redelivered after it are duplicates, batches it had not committed are new (see :class:`~bim2rdt.safety.monitor.
HavMonitor` for the group-commit window).

A store shared by partitioned monitors (the NATS path) holds each one's contribution to a worker-day apart
(:class:`Share`, the store's ``day_parts``): a worker wearing two devices that fall into two partitions is counted
by two processes, and the day is the sum of their rows. Each monitor keeps the whole day in memory (its own
share plus the others', re-read every ``OTHERS_REFRESH_S``, so its EAV/ELV events see the sum) and writes back
only its own share.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass

from bim2rdt.bus import Event
from bim2rdt.bus import AccelBatch
from bim2rdt.bus import partition_of
from bim2rdt.safety.activity import ACTIVITY_ENDED, ACTIVITY_STARTED, ActivityState, DayState, utc_day
from bim2rdt.safety.engine import ExposureEngine, Stream
from bim2rdt.safety.mounting import MountingCorrection
from bim2rdt.safety.retention import RawRetention
from bim2rdt.safety.sessions import Session
from bim2rdt.safety.statecodec import encode_state
from bim2rdt.safety.store import ExposureStore
from bim2rdt.safety.weighing import FilterState


OTHERS_REFRESH_S = 1.0
"""Seconds (of the monitor's clock) between re-reads of the other partitions' shares of the worker-days."""
DayFigures = tuple[dict, "float | None", "float | None"]
"""(hands {hand: [energy, seconds]}, EAV time, ELV time) of a worker-day or of one share of it."""


@dataclass(frozen=True)
class Share:
    """Partition ``partition`` of ``partitions`` of a site's devices: which devices a monitor serves when several
    share one store (``HavMonitor(owns=...)``), and the key of its share of the worker-days ('K/N')."""

    site: str
    partition: int
    partitions: int

    def __call__(self, device: str) -> bool:
        return partition_of(self.site, device, self.partitions) == self.partition

    @property
    def key(self) -> str:
        return f"{self.partition}/{self.partitions}"


class MonitorJournal:
    """Writes an engine's changes to the exposure store and reads them back after a restart."""

    def __init__(self, store: ExposureStore, raw_retention_s: float, retention: RawRetention | None = None):
        """``retention`` None keeps raw batches for ``raw_retention_s`` after receipt, all of them."""
        self.store, self.raw_retention_s, self.retention = store, raw_retention_s, retention
        self._raw_devices: set[str] = set()  # streams that may have raw rows to drop
        self.outbox: list[str] = []
        """Names of the durable sinks: each commit's events are queued for each of them."""
        self.part = ""
        """The key of this monitor's share of the worker-days: '' (the ``days`` rows) unless it serves a
        :class:`Share` (set on restore)."""
        self._others: dict[tuple[str, str], DayFigures] = {}
        """The other shares of each worker-day, as last read: memory holds them plus this monitor's own."""
        self._others_read_at = -float("inf")

    def corrections(self) -> list[MountingCorrection]:
        return [MountingCorrection.from_json(text) for text in self.store.corrections()]

    def restore(self, engine: ExposureEngine, owns: Callable[[str], bool] | None = None) -> None:
        """Put the saved days and streams (with their sessions and waiting batches) back into ``engine``; only the
        streams of the devices it ``owns`` (all by default: a store shared by partitions holds others' too)."""
        if self.retention is not None:
            self.retention.restore()
        self.part = getattr(owns, "key", "") if owns is not None else ""
        self._others = self.store.days(exclude=self.part)
        everyone = self.store.days()
        engine.days.update({key: DayState(*row) for key, row in everyone.items()})  # (hands, eav, elv)
        sessions = self.store.sessions()
        for device, ((buffer_state, activity, clock_offset_s, counters), blob) in self.store.streams().items():
            if owns is not None and not owns(device):
                continue
            buffer = engine.new_buffer()
            next_seq = buffer_state[0]
            buffer.load(buffer_state, self.store.raw_batches(device, next_seq) if next_seq is not None else [])
            saved = sessions.get(device)
            session = Session(**saved) if saved else engine.sessions.anonymous(device)
            engine.restore_stream(device, buffer, FilterState.from_bytes(blob), ActivityState(*activity), session,
                                  clock_offset_s, counters)
            self._raw_devices.add(device)

    def commit(self, engine: ExposureEngine, batches: list[AccelBatch], streams: Iterable[Stream],
               events: list[Event], now: float, sessions: dict[str, Session] | None = None,
               malformed: list[tuple[str, int, str, float | None]] = ()) -> None:
        """One transaction: raw batches, stream states, touched days, events, activities (and sessions, counts
        of refused messages)."""
        streams = list(streams)
        applied = [(b.device, engine.streams[b.device].buffer.boot or "", b.seq, b.received_time) for b in batches]
        if self.raw_retention_s <= 0:
            batches = [b for b in batches if b.seq in engine.streams[b.device].buffer.pending]
        self._raw_devices.update(b.device for b in batches)
        with self.store.transaction():
            self.store.mark_applied(applied, now)
            saved = self.store.save_raw(batches)
            if self.retention is not None:
                self.retention.saved(saved)
            self.store.save_streams((s.device, _stream_state(s), s.filter.to_bytes()) for s in streams)
            self.store.save_activities([_open_activity(engine.streams[e.source]) for e in events
                                        if e.kind == ACTIVITY_STARTED])
            if self.retention is not None and self.raw_retention_s > 0:
                self.retention.note_events(events, _offsets(engine, events), now)
            self._drop_raw(engine, now, streams)
            self._save_days(engine)
            self.store.add_events(events, self.outbox)
            self.store.save_activities([(e.data["activity"], e.subject, e.data["day"], {**e.data, "open": False})
                                        for e in events if e.kind == ACTIVITY_ENDED])
            for device, session in (sessions or {}).items():
                self.store.save_session(device, vars(session))
            self.store.save_malformed(malformed)
        engine.touched_days.clear()
        if now - self._others_read_at >= OTHERS_REFRESH_S:
            self._others_read_at = now
            self._read_others(engine, utc_day(now - 86400.0))

    def _save_days(self, engine: ExposureEngine) -> None:
        """This monitor's share of the touched worker-days: what memory holds minus the other shares."""
        days, others = engine.days, self._others
        if others:
            rows = [(*key, _minus(days[key], others.get(key))) for key in engine.touched_days]
        else:  # no other shares (one monitor per store): memory is this monitor's share
            rows = [(*key, days[key]) for key in engine.touched_days]
        if self.part:
            self.store.save_day_parts(self.part, rows)
        else:
            self.store.save_days(rows)

    def _read_others(self, engine: ExposureEngine, since_day: str) -> None:
        """Add to memory what the other shares counted since they were last read (their EAV/ELV times too)."""
        for key, (hands, eav, elv) in self.store.days(exclude=self.part, since_day=since_day).items():
            before = self._others.get(key, ({}, None, None))
            state = engine.days.get(key)
            if state is None:
                state = engine.days[key] = DayState()
            for hand, (energy, seconds) in hands.items():
                old = before[0].get(hand, (0.0, 0.0))
                if energy != old[0] or seconds != old[1]:
                    state.add(hand, energy - old[0], seconds - old[1])
            state.eav_at = _earliest(state.eav_at, eav)
            state.elv_at = _earliest(state.elv_at, elv)
            self._others[key] = (hands, eav, elv)

    def save_correction(self, correction: MountingCorrection) -> None:
        with self.store.transaction():
            self.store.save_correction(correction.subject, correction.position, correction.to_json())

    def _drop_raw(self, engine: ExposureEngine, now: float, touched: list[Stream]) -> None:
        """Delete processed raw batches past retention, of every stream that stored any; then the recent, event
        and size rules (:mod:`~bim2rdt.safety.retention`) on the streams touched."""
        stored = [engine.streams[d] for d in self._raw_devices if engine.streams[d].buffer.next_seq is not None]
        self.store.drop_raw([(s.device, s.buffer.next_seq) for s in stored], now - self.raw_retention_s)
        if self.raw_retention_s <= 0:
            self._raw_devices.difference_update(s.device for s in stored if not s.buffer.pending)
        elif self.retention is not None:
            self.retention.prune([(s.device, s.buffer.next_seq, s.buffer.last_end) for s in touched
                                  if s.buffer.next_seq is not None], now,
                                 lambda device: engine.streams[device].buffer.next_seq
                                 if device in engine.streams else None)


def _minus(state: DayState, others: DayFigures | None) -> DayState:
    """The share of ``state`` that is not ``others``' (``state`` itself when there are none)."""
    if not others:
        return state
    hands = {}
    for hand, (energy, seconds) in state.hands.items():
        other = others[0].get(hand, (0.0, 0.0))
        if hand not in others[0] or energy != other[0] or seconds != other[1]:
            hands[hand] = [energy - other[0], seconds - other[1]]
    return DayState(hands, state.eav_at, state.elv_at)


def _earliest(a: float | None, b: float | None) -> float | None:
    return b if a is None else a if b is None else min(a, b)


def _offsets(engine: ExposureEngine, events: list[Event]) -> dict[str, float]:
    """Seconds each event source's times were moved onto the receive clock (0 for a device on wall time)."""
    streams = {e.source: engine.streams.get(e.source) for e in events}
    return {device: (s.clock.offset_s or 0.0) if s is not None and s.time_base == "receive" else 0.0
            for device, s in streams.items()}


def _stream_state(stream: Stream) -> str:
    """[buffer, activity, clock offset, counters] as stored text, packed (:mod:`~bim2rdt.safety.statecodec`); saved
    for every touched stream."""
    return encode_state(stream.buffer, stream.tracker.state, stream.clock.offset_s, stream.counters)


def _open_activity(stream: Stream) -> tuple[str, str, str, dict]:
    act, session = stream.tracker.state, stream.session
    return (act.id, session.subject, act.day, {**act.to_dict(), "a_hv": act.a_hv, "tool": session.tool,
                                                "device": stream.device, "zone": session.zone, "open": True})
