"""The streaming hand-arm vibration monitor: wearable batches in, exposure and safety events out.

``HavMonitor`` ingests batches ``(device, seq, device_time, fs, xyz)``; a device is bound to a worker and a
tool by a *session* (from the device's retained status message or :meth:`HavMonitor.start_session`). Per
stream it orders and de-duplicates batches, reports gaps, cuts sine-tapered frames, rejects artefact frames
(NaN, saturation, shocks), applies the subject's mounting correction and the exact Wh weighting in the
frequency domain, and feeds the trigger-time activity tracker. Per worker-day it keeps A(8) and HSE points and
emits: activity started, predicted time to EAV, EAV reached, ELV reached, activity ended (with the day's
exposure), gaps and artefacts. Every ingest is one SQLite transaction (raw batches, stream checkpoints,
activity and day state, events), so a restart mid-shift resumes exactly where it stopped.
"""

from __future__ import annotations

import json
import math
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from bim2rdt.bus.event import Event
from bim2rdt.bus.payloads import AccelBatch, PayloadError, decode_accel
from bim2rdt.bus.topics import device_of, wearable_pattern
from bim2rdt.safety.activity import ACTIVITY_ENDED, ARTEFACT, GAP, ActivityState, ActivityTracker, DayState, Notice, Trigger
from bim2rdt.safety.frames import (ArtefactLimits, FrameSpec, artefact_flags, describe_flags, energy_weights,
                                   frame_energies)
from bim2rdt.safety.mounting import MountingCorrection
from bim2rdt.safety.privacy import IdentityMap, pseudonym
from bim2rdt.safety.sinks import EventSink
from bim2rdt.safety.store import ExposureStore
from bim2rdt.safety.streams import Checkpoint, FrameBlock, PushResult, StreamBuffer
from bim2rdt.safety.weighting import covered_band

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

    @property
    def estimate(self) -> bool:
        return self.position not in ISO_POSITIONS


@dataclass
class _Stream:
    device: str
    buffer: StreamBuffer
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
        self._weights: dict[tuple, np.ndarray] = {}
        self._corrections = {(c.subject, c.position): c for c in map(MountingCorrection.from_json,
                                                                     self.store.corrections())}
        self._days = {key: DayState(**state) for key, state in self.store.days().items()}
        self._streams = {d: self._restore(d, s) for d, s in self.store.streams().items()}
        self._touched_days: set[tuple[str, str]] = set()

    # --- sessions and corrections ---------------------------------------------------------------------
    def start_session(self, device: str, worker: str, tool: str = "unknown", position: str = "handle",
                      zone: str | None = None) -> str:
        """Bind ``device`` to a worker (stored as a pseudonym), a tool, a body position and a work zone."""
        with self._lock:
            subject = pseudonym(worker, self.secret)
            self.identity.remember(subject, worker)
            stream = self._stream(device)
            new = Session(subject, tool, position, zone)
            if stream.session != new:
                events = self._stop_activity(stream, self._last_time(stream))
                stream.session = new
                self._commit([], [stream], events)
            return subject

    def end_session(self, device: str, when: float | None = None) -> list[Event]:
        """The device went offline or the session is over: flush its stream and end its activity."""
        with self._lock:
            stream = self._streams.get(device)
            if stream is None:
                return []
            result = PushResult()
            stream.buffer.close(result)
            events = self._note_gaps(stream, result) + self._track([(stream, b) for b in result.blocks])
            events += self._stop_activity(stream, when if when is not None else self._last_time(stream))
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
        """Take batches from any devices in any order; returns (and emits) the events they caused."""
        with self._lock:
            now = self.clock() if now is None else now
            accepted, touched, blocks, events = [], {}, [], []
            for batch in batches:
                batch = batch if batch.received_time is not None else batch.received_at(now)
                stream = self._stream(batch.device)
                result = stream.buffer.push(batch, now)
                events += self._note_push(stream, batch, result)
                if result.duplicates == result.late == 0:
                    accepted.append(batch)
                touched[stream.device] = stream
                blocks += [(stream, block) for block in result.blocks]
            events += self._track(blocks)
            self._commit(accepted, touched.values(), events, now)
            return events

    def ingest_payload(self, topic: str, payload: bytes, received: float | None = None) -> list[Event]:
        """An MQTT accel message; ignored (and counted) if malformed or its device id is not the topic's."""
        try:
            batch = decode_accel(payload)
        except PayloadError:
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
                               str(status.get("position", "handle")), status.get("zone"))
            return []
        return self.end_session(device) if status.get("online") is False else []

    def tick(self, now: float | None = None) -> list[Event]:
        """Declare overdue gaps on streams whose missing batches never came."""
        with self._lock:
            now = self.clock() if now is None else now
            waiting = [s for s in self._streams.values() if s.buffer.pending]
            events, blocks = [], []
            for stream in waiting:
                result = PushResult()
                stream.buffer.expire(now, result)
                events += self._note_gaps(stream, result)
                blocks += [(stream, b) for b in result.blocks]
            events += self._track(blocks)
            if waiting:
                self._commit([], waiting, events, now)
            return events

    def attach(self, bus) -> None:
        """Subscribe to every wearable's accel and status topics of the configured site on ``bus``."""
        bus.subscribe(wearable_pattern(self.config.site, "status"), self.on_status, qos=1)
        bus.subscribe(wearable_pattern(self.config.site, "accel"), self.ingest_payload, qos=1)

    # --- reading --------------------------------------------------------------------------------------
    def day(self, subject: str, day: str | None = None) -> DayState:
        """The worker-day's exposure (A(8), points, trigger time); today (UTC) by default."""
        with self._lock:
            return self._days.get((subject, day or _day_key(self.clock())), DayState())

    def session(self, device: str) -> Session | None:
        stream = self._streams.get(device)
        return stream.session if stream else None

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
            subject = pseudonym(f"device:{device}", self.secret)
            stream = _Stream(device, self._buffer(device), ActivityTracker(self.config.trigger, device),
                             Session(subject, position="unknown"))
            self._streams[device] = stream
        return stream

    def _buffer(self, device: str) -> StreamBuffer:
        return StreamBuffer(device, self.config.max_reorder, self.config.reorder_s)

    def _note_push(self, stream: _Stream, batch: AccelBatch, result: PushResult) -> list[Event]:
        stream.count("batches")
        stream.count("duplicates", result.duplicates)
        stream.count("late", result.late)
        for name in ("duplicates", "late"):
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
    def _track(self, blocks: list[tuple[_Stream, FrameBlock]]) -> list[Event]:
        """Weigh every frame of ``blocks`` (batched FFTs per weighting) then run each stream's tracker."""
        if not blocks:
            return []
        energies, flags = self._weigh(blocks)
        events = []
        for (stream, block), energy, flag in zip(blocks, energies, flags):
            events += self._track_block(stream, block, energy, flag)
        return events

    def _weigh(self, blocks: list[tuple[_Stream, FrameBlock]]) -> tuple[list[np.ndarray], list[np.ndarray]]:
        groups: dict[tuple, list[int]] = {}
        for i, (stream, block) in enumerate(blocks):
            groups.setdefault(self._weight_key(stream, block), []).append(i)
        energies, flags = [None] * len(blocks), [None] * len(blocks)
        for key, members in groups.items():
            frames = np.concatenate([blocks[i][1].frames for i in members])
            scale = np.concatenate([np.full(len(blocks[i][1].frames), blocks[i][1].full_scale) for i in members])
            group_flags = artefact_flags(frames, scale, self.config.artefacts)
            group_energy = frame_energies(frames, FrameSpec(key[0], key[1]), self._weights_for(key)).sum(axis=1)
            splits = np.cumsum([len(blocks[i][1].frames) for i in members])[:-1]
            for i, e, f in zip(members, np.split(group_energy, splits), np.split(group_flags, splits)):
                energies[i], flags[i] = e, f
        return energies, flags

    def _weight_key(self, stream: _Stream, block: FrameBlock) -> tuple:
        spec = stream.buffer.spec
        correction = self._correction(stream.session)
        return (spec.fs, block.frames.shape[-1], (correction.subject, correction.position) if correction else None)

    def _weights_for(self, key: tuple) -> np.ndarray:
        if key not in self._weights:
            spec = FrameSpec(key[0], key[1])
            correction = self._corrections.get(key[2]) if key[2] else None
            gain = None
            if correction is not None:
                gain = correction.gain_at(np.fft.rfftfreq(spec.length, 1.0 / spec.fs))
            self._weights[key] = energy_weights(spec, gain)
        return self._weights[key]

    def _correction(self, session: Session) -> MountingCorrection | None:
        return self._corrections.get((session.subject, session.position)) if session.estimate else None

    def _track_block(self, stream: _Stream, block: FrameBlock, energy: np.ndarray, flags: np.ndarray) -> list[Event]:
        notices: list[Notice] = []
        tracker, subject = stream.tracker, stream.session.subject
        day_of = self._day_lookup(subject)
        for end, seconds, e, flag in zip(block.end_time.tolist(), block.seconds.tolist(), energy.tolist(),
                                         flags.tolist()):
            if flag:
                tracker.reject(seconds)
                stream.count("rejected_s", seconds)
                notices.append((ARTEFACT, end - seconds, {"seconds": seconds, "kinds": describe_flags(flag)}))
                continue
            notices += tracker.frame(end, seconds, e, _day_key(end - seconds), day_of)
            if self.config.keep_timeline and tracker.state.id is not None:
                self.timeline.append((end, subject, day_of(tracker.state.day).a8))
        return [self._event(stream, notice) for notice in notices]

    def _day_lookup(self, subject: str) -> Callable[[str], DayState]:
        def day_of(day: str) -> DayState:
            self._touched_days.add((subject, day))
            return self._days.setdefault((subject, day), DayState())

        return day_of

    def _stop_activity(self, stream: _Stream, when: float) -> list[Event]:
        notices = stream.tracker.stop(when, self._day_lookup(stream.session.subject))
        return [self._event(stream, notice) for notice in notices]

    def _last_time(self, stream: _Stream) -> float:
        buffer = stream.buffer
        return buffer.seg_t0 + buffer.seg_end / buffer.spec.fs if buffer.spec else self.clock()

    # --- internals: events and persistence ------------------------------------------------------------
    def _event(self, stream: _Stream, notice: Notice) -> Event:
        kind, when, data = notice
        session, spec = stream.session, stream.buffer.spec
        coverage = covered_band(spec.fs) if spec else None
        day = self._days.get((session.subject, data.get("day", _day_key(when))), DayState())
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
        now = self.clock() if now is None else now
        with self.store.transaction():
            self.store.save_raw(batches)
            for stream in streams:
                self._save_stream(stream, now)
            for subject, day in self._touched_days:
                self.store.save_day(subject, day, asdict(self._days[(subject, day)]))
            self.store.add_events(events)
            for event in events:
                if event.kind == ACTIVITY_ENDED:
                    self.store.save_activity(event.data["activity"], event.subject, event.data["day"],
                                             {**event.data, "open": False})
        self._touched_days.clear()
        for event in events:
            for sink in self.sinks:
                sink.emit(event)

    def _save_stream(self, stream: _Stream, now: float) -> None:
        point = stream.buffer.checkpoint()
        self.store.save_stream(stream.device, {
            "checkpoint": asdict(point), "activity": stream.tracker.state.to_dict(),
            "session": asdict(stream.session), "clock_offset_s": stream.clock_offset_s,
            "counters": stream.counters})
        act = stream.tracker.state
        if act.id is not None:
            self.store.save_activity(act.id, stream.session.subject, act.day,
                                     {**act.to_dict(), "a_hv": act.a_hv, "tool": stream.session.tool,
                                      "device": stream.device, "zone": stream.session.zone, "open": True})
        if point.resume_seq is not None:
            self.store.drop_raw(stream.device, point.resume_seq, now - self.config.raw_retention_s)

    def _restore(self, device: str, state: dict) -> _Stream:
        buffer = self._buffer(device)
        point = Checkpoint(**state["checkpoint"])
        if point.resume_seq is not None:
            buffer.restore(point, self.store.raw_batches(device, point.resume_seq))
        tracker = ActivityTracker(self.config.trigger, device, ActivityState(**state["activity"]))
        return _Stream(device, buffer, tracker, Session(**state["session"]), state["clock_offset_s"],
                       state["counters"])

    def _count(self, name: str, amount: float = 1) -> None:
        self.stats[name] = self.stats.get(name, 0) + amount


def _day_key(when: float) -> str:
    return time.strftime("%Y-%m-%d", time.gmtime(when))


def _finite(body: dict) -> dict:
    """JSON has no inf/NaN: unbounded times become None."""
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in body.items()}
