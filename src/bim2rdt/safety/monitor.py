"""The streaming hand-arm vibration monitor: wearable batches in, exposure and safety events out.

``HavMonitor`` ingests batches ``(device, seq, device_time, fs, xyz)``; a device is bound to a worker and a tool
by a *session* (from the device's retained status message or :meth:`HavMonitor.start_session`). Per stream it
orders and de-duplicates batches, reports gaps, weighs samples with the fitted Wh IIR (after the subject's
mounting correction, if any) with state carried across batches, rejects artefact blocks (NaN, saturation,
shocks) and feeds half-second blocks to the trigger-time activity tracker. Per worker-day it keeps A(8) and HSE
points and emits: activity started, predicted time to EAV, EAV reached, ELV reached, activity ended (with the
day's exposure), gaps and artefacts. Every ingest is one SQLite transaction (stream order and filter state,
activity and day state, events, raw batches while retained), so a restart mid-shift resumes where it stopped.
"""

from __future__ import annotations

import json
import math
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from bim2rdt.bus.event import Event
from bim2rdt.bus.payloads import AccelBatch, PayloadError, decode_accel
from bim2rdt.bus.topics import device_of, wearable_pattern
from bim2rdt.safety.activity import (ACTIVITY_ENDED, ACTIVITY_STARTED, ARTEFACT, GAP, ActivityState, ActivityTracker,
                                     DayState, Notice, Trigger, utc_day)
from bim2rdt.safety.blocks import ArtefactLimits, describe_flags
from bim2rdt.safety.mounting import MountingCorrection
from bim2rdt.safety.privacy import IdentityMap, pseudonym
from bim2rdt.safety.sinks import EventSink
from bim2rdt.safety.store import ExposureStore
from bim2rdt.safety.streams import PushResult, StreamBuffer
from bim2rdt.safety.weighing import Blocks, FilterState, Piece, weigh_round
from bim2rdt.safety.errors import HavError
from bim2rdt.safety.weighting import covered_band, require_weighable_rate

ISO_POSITIONS = ("handle",)
"""Positions where ISO 5349-1 measures (at the hand-tool interface): no correction, not an estimate."""


@dataclass(frozen=True)
class MonitorConfig:
    """How the monitor detects activities, rejects artefacts, waits for late batches and keeps raw data."""

    site: str = "demo"
    trigger: Trigger = Trigger()
    artefacts: ArtefactLimits = ArtefactLimits()
    max_reorder: int = 8
    """Out-of-order batches held before a missing seq is declared a gap."""
    reorder_s: float = 2.0
    """Seconds a batch waits for a missing predecessor before it is declared a gap."""
    raw_retention_s: float = 7 * 24 * 3600.0
    """Raw batches are deleted this long after receipt once framed (0: as soon as framed)."""
    keep_timeline: bool = False
    """Keep (time, subject, A(8)) after every counted frame (for plots of the day)."""


@dataclass
class Session:
    """Who wears a device, on which tool, where on the body and in which work zone."""

    subject: str
    tool: str = "unknown"
    position: str = "handle"
    zone: str | None = None
    hand: str = ""
    """'left' or 'right' when known: with both hands exposed the day counts the greater one."""

    @property
    def estimate(self) -> bool:
        return self.position not in ISO_POSITIONS


@dataclass
class _Stream:
    device: str
    buffer: StreamBuffer
    filter: FilterState
    tracker: ActivityTracker
    session: Session
    clock_offset_s: float | None = None
    counters: dict[str, float] = field(default_factory=dict)

    def count(self, name: str, amount: float = 1) -> None:
        self.counters[name] = self.counters.get(name, 0) + amount


class HavMonitor:
    """Streaming ISO 5349-1 exposure for many wearables; thread-safe (one lock around each call)."""

    def __init__(self, data_dir: Path, site_secret: str, sinks: Sequence[EventSink] = (),
                 config: MonitorConfig = MonitorConfig(), clock: Callable[[], float] = time.time):
        self.config, self.sinks, self.clock, self.secret = config, list(sinks), clock, site_secret
        self.store = ExposureStore(Path(data_dir) / "hav.sqlite")
        self.identity = IdentityMap(Path(data_dir) / "private" / "identity.sqlite", role="monitor")
        self.stats: dict[str, float] = {}
        self.timeline: list[tuple[float, str, float]] = []
        self._lock = threading.RLock()
        self._corrections = {(c.subject, c.position): c for c in map(MountingCorrection.from_json,
                                                                     self.store.corrections())}
        self._days = {key: DayState(*row) for key, row in self.store.days().items()}  # (hands, eav_at, elv_at)
        sessions = self.store.sessions()
        self._streams = {d: self._restore(d, row, sessions.get(d)) for d, row in self.store.streams().items()}
        self._touched_days: set[tuple[str, str]] = set()
        self._raw_devices: set[str] = set(self._streams)  # streams that may have raw rows to drop

    # --- sessions and corrections ---------------------------------------------------------------------
    def start_session(self, device: str, worker: str, tool: str = "unknown", position: str = "handle",
                      zone: str | None = None, hand: str = "") -> str:
        """Bind ``device`` to a worker (stored as a pseudonym), a tool, a body position, a work zone and a hand."""
        with self._lock:
            subject = pseudonym(worker, self.secret)
            self.identity.remember(subject, worker)
            stream = self._stream(device)
            new = Session(subject, tool, position, zone, hand)
            if stream.session != new:
                events = self._stop_activity(stream, self._last_time(stream))
                stream.session, stream.tracker.hand = new, hand
                self._commit([], [stream], events)
                with self.store.transaction():
                    self.store.save_session(device, vars(new))
            return subject

    def end_session(self, device: str, when: float | None = None) -> list[Event]:
        """The device went offline or the session is over: flush its stream and end its activity at ``when``
        (default: the device time of its last sample, not when the news reached us)."""
        with self._lock:
            stream = self._streams.get(device)
            if stream is None:
                return []
            result = PushResult()
            last = stream.buffer.close(result)
            events = self._note_gaps(stream, result) + self._process([(stream, b, s) for b, s in result.pieces])
            when = when if when is not None else last if last is not None else self.clock()
            events += self._stop_activity(stream, when)
            self._commit([], [stream], events)
            return events

    def add_correction(self, correction: MountingCorrection) -> None:
        """Use ``correction`` for every stream of that subject at that position (persisted)."""
        with self._lock:
            self._corrections[(correction.subject, correction.position)] = correction
            with self.store.transaction():
                self.store.save_correction(correction.subject, correction.position, correction.to_json())

    # --- ingest ---------------------------------------------------------------------------------------
    def ingest(self, batch: AccelBatch) -> list[Event]:
        return self.ingest_many([batch])

    def ingest_many(self, batches: Iterable[AccelBatch], now: float | None = None) -> list[Event]:
        """Take batches from any devices in any order; returns (and emits) the events they caused. HavError,
        before any state changes, if a batch's rate is too low to weigh."""
        batches = list(batches)
        for batch in batches:
            require_weighable_rate(batch.fs)
        with self._lock:
            now = self.clock() if now is None else now
            accepted, touched, ordered, events = [], {}, [], []
            for batch in batches:
                batch = batch if batch.received_time is not None else batch.received_at(now)
                stream = self._stream(batch.device)
                result = stream.buffer.push(batch, now)
                events += self._note_push(stream, batch, result)
                if result.duplicates == result.late == 0:
                    accepted.append(batch)
                touched[stream.device] = stream
                ordered += [(stream, piece, new_segment) for piece, new_segment in result.pieces]
            events += self._process(ordered)
            self._commit(accepted, touched.values(), events, now)
            return events

    def ingest_payload(self, topic: str, payload: bytes, received: float | None = None) -> list[Event]:
        """An MQTT accel message; ignored (and counted) if malformed, too slowly sampled to weigh, or its device
        id is not the topic's (a handler must never raise: it would stop the MQTT client's network thread)."""
        try:
            batch = decode_accel(payload)
            require_weighable_rate(batch.fs)
        except (PayloadError, HavError):
            self._count("malformed")
            return []
        if batch.device != device_of(topic):
            self._count("mismatched")
            return []
        return self.ingest_many([batch.received_at(self.clock() if received is None else received)])

    def on_status(self, topic: str, payload: bytes) -> list[Event]:
        """A wearable's retained status: online with a worker starts a session, offline ends it."""
        device = device_of(topic)
        try:
            status = json.loads(payload)
        except ValueError:
            self._count("malformed")
            return []
        if device is None or not isinstance(status, dict):
            return []
        if status.get("online") and status.get("worker"):
            self.start_session(device, str(status["worker"]), str(status.get("tool", "unknown")),
                               str(status.get("position", "handle")), status.get("zone"), str(status.get("hand", "")))
            return []
        return self.end_session(device) if status.get("online") is False else []

    def tick(self, now: float | None = None) -> list[Event]:
        """Declare overdue gaps on streams whose missing batches never came."""
        with self._lock:
            now = self.clock() if now is None else now
            waiting = [s for s in self._streams.values() if s.buffer.pending]
            events, ordered = [], []
            for stream in waiting:
                result = PushResult()
                stream.buffer.expire(now, result)
                events += self._note_gaps(stream, result)
                ordered += [(stream, piece, new_segment) for piece, new_segment in result.pieces]
            events += self._process(ordered)
            if waiting:
                self._commit([], waiting, events, now)
            return events

    def attach(self, bus) -> None:
        """Subscribe to every wearable's accel and status topics of the configured site on ``bus`` (attach
        before connecting an MQTT bus with a persistent session, so queued messages find their handler)."""
        bus.subscribe(wearable_pattern(self.config.site, "status"), self.on_status, qos=1)
        bus.subscribe(wearable_pattern(self.config.site, "accel"), self.ingest_payload, qos=1)

    # --- reading --------------------------------------------------------------------------------------
    def day(self, subject: str, day: str | None = None) -> DayState:
        """The worker-day's exposure (A(8), points, trigger time); today (UTC) by default."""
        with self._lock:
            return self._days.get((subject, day or utc_day(self.clock())), DayState())

    def days_of(self, subject: str) -> list[str]:
        """The days (UTC, 'YYYY-MM-DD') with exposure on record for a worker, oldest first."""
        with self._lock:
            return sorted(day for who, day in self._days if who == subject)

    def devices(self) -> list[str]:
        """Every device the monitor has seen (or restored)."""
        with self._lock:
            return list(self._streams)

    def session(self, device: str) -> Session | None:
        stream = self._streams.get(device)
        return stream.session if stream else None

    def stream_status(self, device: str) -> dict | None:
        """Where a device's stream stands: next expected seq, batches waiting, counters, clock offset (s)."""
        with self._lock:
            stream = self._streams.get(device)
            if stream is None:
                return None
            return {"next_seq": stream.buffer.next_seq, "waiting": sorted(stream.buffer.pending),
                    "clock_offset_s": stream.clock_offset_s, **stream.counters}

    def activity(self, device: str) -> ActivityState | None:
        stream = self._streams.get(device)
        return stream.tracker.state if stream else None

    def close(self) -> None:
        self.store.close()
        self.identity.close()

    # --- internals: streams ---------------------------------------------------------------------------
    def _stream(self, device: str) -> _Stream:
        stream = self._streams.get(device)
        if stream is None:
            stream = _Stream(device, self._buffer(), FilterState(), ActivityTracker(self.config.trigger, device),
                             self._anonymous_session(device))
            self._streams[device] = stream
        return stream

    def _anonymous_session(self, device: str) -> Session:
        """A device nobody has claimed yet: its own pseudonym, unknown tool and position (an estimate)."""
        return Session(pseudonym(f"device:{device}", self.secret), position="unknown")

    def _buffer(self) -> StreamBuffer:
        return StreamBuffer(self.config.max_reorder, self.config.reorder_s)

    def _note_push(self, stream: _Stream, batch: AccelBatch, result: PushResult) -> list[Event]:
        stream.count("batches")
        for name in ("duplicates", "late"):
            if getattr(result, name):
                stream.count(name, getattr(result, name))
                self._count(name, getattr(result, name))
        if result.duplicates == result.late == 0:
            # receive time minus device time of the last sample = clock skew + delivery delay; the least
            # delayed batches show the skew, so follow drops at once and rises slowly (clocks drift)
            offset = batch.received_time - (batch.device_time + batch.duration_s)
            previous = stream.clock_offset_s
            stream.clock_offset_s = offset if previous is None or offset < previous else 0.99 * previous + 0.01 * offset
        return self._note_gaps(stream, result)

    def _note_gaps(self, stream: _Stream, result: PushResult) -> list[Event]:
        events = []
        for gap in result.gaps:
            seconds = max(gap.end - gap.start, 0.0)
            stream.count("gaps")
            stream.count("gap_s", seconds)
            self._count("gaps")
            stream.tracker.gap(seconds)
            events.append(self._event(stream, (GAP, gap.start, {"end": gap.end, "seconds": seconds,
                                                                 "reason": gap.reason,
                                                                 "missing_batches": gap.missing_seqs})))
        return events

    # --- internals: weighting and tracking ------------------------------------------------------------
    def _process(self, ordered: list[tuple[_Stream, AccelBatch, bool]]) -> list[Event]:
        """Weigh in-order batches in rounds (one batch per stream per round) and track the blocks."""
        queues: dict[str, list[Piece]] = {}
        for stream, batch, new_segment in ordered:
            piece = Piece(stream.filter, batch, new_segment, self._correction(stream.session))
            queues.setdefault(stream.device, []).append(piece)
        events = []
        for r in range(max((len(q) for q in queues.values()), default=0)):
            devices = [d for d, q in queues.items() if len(q) > r]
            finished = weigh_round([queues[d][r] for d in devices], self.config.artefacts)
            for device, blocks in zip(devices, finished):
                events += self._track(self._streams[device], blocks)
        return events

    def _track(self, stream: _Stream, blocks: Blocks) -> list[Event]:
        notices: list[Notice] = []
        tracker, subject = stream.tracker, stream.session.subject
        day_of = self._day_lookup(subject)
        for end, seconds, energy, flags in zip(blocks.end, blocks.seconds, blocks.energy, blocks.flags):
            if flags:
                tracker.reject(seconds)
                stream.count("rejected_s", seconds)
                notices.append((ARTEFACT, end - seconds, {"seconds": seconds, "kinds": describe_flags(flags)}))
                continue
            notices += tracker.frame(end, seconds, energy, day_of)
            if self.config.keep_timeline and tracker.state.id is not None:
                self.timeline.append((end, subject, day_of(tracker.state.day).a8))
        return [self._event(stream, notice) for notice in notices]

    def _correction(self, session: Session) -> MountingCorrection | None:
        return self._corrections.get((session.subject, session.position)) if session.estimate else None

    def _day_lookup(self, subject: str) -> Callable[[str], DayState]:
        def day_of(day: str) -> DayState:
            self._touched_days.add((subject, day))
            return self._days.setdefault((subject, day), DayState())

        return day_of

    def _stop_activity(self, stream: _Stream, when: float) -> list[Event]:
        notices = stream.tracker.stop(when, self._day_lookup(stream.session.subject))
        return [self._event(stream, notice) for notice in notices]

    def _last_time(self, stream: _Stream) -> float:
        return stream.buffer.end_time if stream.buffer.end_time is not None else self.clock()

    # --- internals: events and persistence ------------------------------------------------------------
    def _event(self, stream: _Stream, notice: Notice) -> Event:
        kind, when, data = notice
        session, fs = stream.session, stream.buffer.fs
        coverage = covered_band(fs) if fs else None
        day = self._days.get((session.subject, data.get("day", utc_day(when))), DayState())
        body = {"site": self.config.site, "device": stream.device, "tool": session.tool,
                "position": session.position, "zone": session.zone, "estimate": session.estimate,
                "corrected": self._correction(session) is not None, "a_hv": stream.tracker.state.a_hv,
                "day_a8": day.a8, "day_points": day.points, "risk": day.risk,
                "band_hz": [coverage.low_hz, coverage.high_hz] if coverage else None,
                "band_limited": bool(coverage and not coverage.complete), "clock_offset_s": stream.clock_offset_s}
        body.update(data)
        received = self.clock()
        return Event(kind, float(when), session.subject, stream.device, _finite(body), received)

    def _commit(self, batches: list[AccelBatch], streams: Iterable[_Stream], events: list[Event],
                now: float | None = None) -> None:
        """One transaction: raw batches (all if retained, else only those still waiting), stream states,
        touched days, events, finished activities; then the sinks see the events."""
        now = self.clock() if now is None else now
        streams = list(streams)
        if self.config.raw_retention_s <= 0:
            batches = [b for b in batches if b.seq in self._streams[b.device].buffer.pending]
        self._raw_devices.update(b.device for b in batches)
        with self.store.transaction():
            self.store.save_raw(batches)
            self.store.save_streams([(s.device, self._stream_state(s), s.filter.to_bytes()) for s in streams])
            self.store.save_activities([self._open_activity(self._streams[e.source]) for e in events
                                        if e.kind == ACTIVITY_STARTED])
            self._drop_raw(streams, now)
            self.store.save_days([(subject, day, self._days[(subject, day)]) for subject, day in self._touched_days])
            self.store.add_events(events)
            self.store.save_activities([(e.data["activity"], e.subject, e.data["day"], {**e.data, "open": False})
                                        for e in events if e.kind == ACTIVITY_ENDED])
        self._touched_days.clear()
        for event in events:
            for sink in self.sinks:
                sink.emit(event)

    def _drop_raw(self, streams: list[_Stream], now: float) -> None:
        """Delete processed raw batches past retention, of every stream that stored any."""
        stored = [s for s in self._streams.values() if s.device in self._raw_devices and s.buffer.next_seq is not None]
        self.store.drop_raw([(s.device, s.buffer.next_seq) for s in stored], now - self.config.raw_retention_s)
        if self.config.raw_retention_s <= 0:
            self._raw_devices.difference_update(s.device for s in stored if not s.buffer.pending)

    def _stream_state(self, stream: _Stream) -> list:
        """[buffer, activity, clock offset, counters]: a flat JSON list, saved for every stream on every ingest."""
        return [stream.buffer.to_list(), stream.tracker.state.to_list(), stream.clock_offset_s, stream.counters]

    def _open_activity(self, stream: _Stream) -> tuple[str, str, str, dict]:
        act, session = stream.tracker.state, stream.session
        return (act.id, session.subject, act.day, {**act.to_dict(), "a_hv": act.a_hv, "tool": session.tool,
                                                    "device": stream.device, "zone": session.zone, "open": True})

    def _restore(self, device: str, row: tuple[list, bytes], session: dict | None) -> _Stream:
        (buffer_state, activity, clock_offset_s, counters), blob = row
        buffer = self._buffer()
        next_seq = buffer_state[0]
        buffer.load(buffer_state, self.store.raw_batches(device, next_seq) if next_seq is not None else [])
        session = Session(**session) if session else self._anonymous_session(device)
        tracker = ActivityTracker(self.config.trigger, device, ActivityState(*activity), session.hand)
        return _Stream(device, buffer, FilterState.from_bytes(blob), tracker, session, clock_offset_s, counters)

    def _count(self, name: str, amount: float = 1) -> None:
        self.stats[name] = self.stats.get(name, 0) + amount


def _finite(body: dict) -> dict:
    """JSON has no inf/NaN: unbounded times become None."""
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in body.items()}
