"""The in-memory exposure engine: wearable batches in, safety events out; no I/O.

Per stream it orders and de-duplicates batches and reports gaps (:mod:`~bim2rdt.safety.streams`), weighs samples
with the fitted Wh IIR after the subject's mounting correction, state carried across batches
(:mod:`~bim2rdt.safety.weighing`), rejects artefact blocks and feeds half-second blocks to the trigger-time
activity tracker (:mod:`~bim2rdt.safety.activity`). Per worker-day it keeps A(8) and HSE points. The events it
returns are what the monitor commits and hands to its sinks.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

from bim2rdt.bus import Event
from bim2rdt.bus import AccelBatch
from bim2rdt.safety.activity import ARTEFACT, GAP, ActivityState, ActivityTracker, DayState, Notice, utc_day
from bim2rdt.safety.blocks import describe_flags
from bim2rdt.safety.clock import DeviceClock
from bim2rdt.safety.config import MonitorConfig
from bim2rdt.safety.sessions import Session, SessionBook
from bim2rdt.safety.streams import PushResult, StreamBuffer
from bim2rdt.safety.weighing import Blocks, FilterState, Piece, weigh_round
from bim2rdt.safety.weighting import covered_band


@dataclass(slots=True)
class Stream:
    """One device's stream: ordering buffer, filter state, activity tracker, session, clock and counters."""

    device: str
    buffer: StreamBuffer
    filter: FilterState
    tracker: ActivityTracker
    session: Session
    clock: DeviceClock = field(default_factory=DeviceClock)
    counters: dict[str, float] = field(default_factory=dict)

    def count(self, name: str, amount: float = 1) -> None:
        self.counters[name] = self.counters.get(name, 0) + amount

    def placed(self, device_time: float) -> float:
        """``device_time`` on the wall clock: as it is, or on the receive clock for a device without wall time."""
        return device_time + self.clock.shift(device_time)

    @property
    def time_base(self) -> str:
        """'receive' while the device's times are placed on the receive clock (no wall time), else 'device'."""
        last = self.buffer.last_end
        return "receive" if last is not None and self.clock.shift(last) else "device"


@dataclass
class Outcome:
    """What one call changed: batches accepted (not duplicates or late), streams touched, events caused."""

    accepted: list[AccelBatch] = field(default_factory=list)
    streams: dict[str, Stream] = field(default_factory=dict)
    events: list[Event] = field(default_factory=list)


class ExposureEngine:
    """Streams and worker-days in memory; the monitor persists what each call returns."""

    def __init__(self, config: MonitorConfig, sessions: SessionBook, clock: Callable[[], float]):
        self.config, self.sessions, self.clock = config, sessions, clock
        self.streams: dict[str, Stream] = {}
        self.days: dict[tuple[str, str], DayState] = {}
        self.touched_days: set[tuple[str, str]] = set()
        self.timeline: list[tuple[float, str, float]] = []
        self.stats: dict[str, float] = {}

    # --- streams -------------------------------------------------------------------------------------------
    def stream(self, device: str) -> Stream:
        """The device's stream, created (anonymous session) on first sight."""
        stream = self.streams.get(device)
        if stream is None:
            stream = Stream(device, self.new_buffer(), FilterState(),
                            ActivityTracker(self.config.trigger, device), self.sessions.anonymous(device))
            self.streams[device] = stream
        return stream

    def new_buffer(self) -> StreamBuffer:
        return StreamBuffer(self.config.max_reorder, self.config.reorder_s)

    def count(self, name: str, amount: float = 1) -> None:
        self.stats[name] = self.stats.get(name, 0) + amount

    # --- ingest --------------------------------------------------------------------------------------------
    def push(self, batches: Iterable[AccelBatch], now: float) -> Outcome:
        """Take batches (received at ``now`` unless stamped) from any devices in any order."""
        outcome, ordered, streams = Outcome(), [], self.streams
        for batch in batches:  # runs for every batch: no call or list that the common case does not need
            if batch.received_time is None:
                batch = batch.received_at(now)
            stream = streams.get(batch.device) or self.stream(batch.device)
            result = stream.buffer.push(batch, now)
            events = self._note_push(stream, batch, result)
            if events:
                outcome.events += events
            if result.duplicates == result.late == 0:
                outcome.accepted.append(result.renumbered or batch)
            outcome.streams[stream.device] = stream
            for piece, new_segment in result.pieces:
                ordered.append((stream, piece, new_segment))
        outcome.events += self._process(ordered)
        return outcome

    def expire(self, now: float) -> Outcome:
        """Declare overdue gaps on streams whose missing batches never came."""
        outcome, ordered = Outcome(), []
        for stream in [s for s in self.streams.values() if s.buffer.pending]:
            result = PushResult()
            stream.buffer.expire(now, result)
            outcome.events += self._note_gaps(stream, result)
            outcome.streams[stream.device] = stream
            ordered += [(stream, piece, new_segment) for piece, new_segment in result.pieces]
        outcome.events += self._process(ordered)
        return outcome

    def close(self, device: str, when: float | None = None) -> Outcome:
        """Flush a stream's waiting batches and end its activity at ``when`` (default: the device time of its
        last sample, not when the news reached us)."""
        stream = self.streams.get(device)
        if stream is None:
            return Outcome()
        result = PushResult()
        last = stream.buffer.close(result)
        events = self._note_gaps(stream, result) + self._process([(stream, b, s) for b, s in result.pieces])
        when = when if when is not None else stream.placed(last) if last is not None else self.clock()
        return Outcome([], {device: stream}, events + self.stop_activity(stream, when))

    def rebind(self, device: str, session: Session) -> Outcome:
        """Put ``device`` under ``session``; a running activity of the old session ends first."""
        stream = self.stream(device)
        if stream.session == session:
            return Outcome()
        events = self.stop_activity(stream, self.last_time(stream))
        stream.session, stream.tracker.hand = session, session.hand
        return Outcome([], {device: stream}, events)

    def stop_activity(self, stream: Stream, when: float) -> list[Event]:
        notices = stream.tracker.stop(when, self._day_lookup(stream.session.subject))
        return [self.event(stream, notice) for notice in notices]

    def last_time(self, stream: Stream) -> float:
        return stream.placed(stream.buffer.end_time) if stream.buffer.end_time is not None else self.clock()

    # --- order, gaps and clock -----------------------------------------------------------------------------
    def _note_push(self, stream: Stream, batch: AccelBatch, result: PushResult) -> list[Event] | tuple[()]:
        counters = stream.counters  # stream.count("batches"), written out: this runs for every batch
        counters["batches"] = counters.get("batches", 0) + 1
        if result.duplicates:
            stream.count("duplicates", result.duplicates)
            self.count("duplicates", result.duplicates)
        if result.late:
            stream.count("late", result.late)
            self.count("late", result.late)
        if result.renumberings:
            stream.count("renumbered", result.renumberings)
        if result.restarts:  # a new epoch on a reset device clock: the old lag says nothing about the new clock
            stream.count("restarts", result.restarts)
            stream.clock = DeviceClock()
        if result.duplicates == result.late == 0:
            stream.clock.observe(batch.received_time, batch.device_time + batch.duration_s)
        return self._note_gaps(stream, result) if result.gaps else ()

    def _note_gaps(self, stream: Stream, result: PushResult) -> list[Event]:
        events = []
        for gap in result.gaps:
            seconds, shift = max(gap.end - gap.start, 0.0), stream.clock.shift(gap.start)
            stream.count("gaps")
            stream.count("gap_s", seconds)
            self.count("gaps")
            stream.tracker.gap(seconds)
            end = gap.end + stream.clock.shift(gap.end)  # a clock that jumped back: its end is placed apart
            events.append(self.event(stream, (GAP, gap.start + shift, {"end": end, "seconds": seconds,
                                                                "reason": gap.reason,
                                                                "missing_batches": gap.missing_seqs})))
        return events

    # --- weighting and tracking ----------------------------------------------------------------------------
    def _process(self, ordered: list[tuple[Stream, AccelBatch, bool]]) -> list[Event]:
        """Weigh in-order batches, each stream's consecutive ones as one run, in rounds (one run per stream per
        round); then track every stream's blocks in device-time order."""
        runs: dict[str, list[Piece]] = {}
        rounds = 1
        for stream, batch, new_segment in ordered:
            queue = runs.get(stream.device)
            if queue is None:
                runs[stream.device] = [Piece(stream.filter, [batch], new_segment,
                                             self.sessions.correction(stream.session))]
            elif not new_segment and _continues(queue[-1], batch):
                queue[-1].batches.append(batch)
            else:
                queue.append(Piece(stream.filter, [batch], new_segment, self.sessions.correction(stream.session)))
                rounds = max(rounds, len(queue))
        if rounds == 1:  # the usual case: one run per stream, so one round
            pieces = [queue[0] for queue in runs.values()]
            return self._track(dict(zip(runs, [[blocks] for blocks in weigh_round(pieces, self.config.artefacts)])))
        weighed: dict[str, list[Blocks]] = {device: [] for device in runs}
        for r in range(max((len(q) for q in runs.values()), default=0)):
            devices = [d for d, q in runs.items() if len(q) > r]
            for device, blocks in zip(devices, weigh_round([runs[d][r] for d in devices], self.config.artefacts)):
                weighed[device].append(blocks)
        return self._track(weighed)

    def _track(self, weighed: dict[str, list[Blocks]]) -> list[Event]:
        """Feed blocks to the trackers; the streams of one worker merged by block end time (each stream's own order
        kept), so two devices of one worker reach a limit in the order their samples were taken."""
        streams, by_subject = self.streams, {}  # subject: its device, or its devices when it has several
        for device in weighed:
            subject = streams[device].session.subject
            known = by_subject.get(subject)
            if known is None:
                by_subject[subject] = device
            elif known.__class__ is str:
                by_subject[subject] = [known, device]
            else:
                known.append(device)
        events = []
        for subject, devices in by_subject.items():
            day_of = self._day_lookup(subject)
            if devices.__class__ is str:
                events += self._track_stream(streams[devices], weighed[devices], day_of)
                continue
            for end, _, device, seconds, energy, flags in heapq.merge(*(_stream_blocks(weighed[d], self.streams[d])
                                                                         for d in devices)):
                events += self._frame(self.streams[device], day_of, end, seconds, energy, flags)
        return events

    def _track_stream(self, stream: Stream, runs: list[Blocks], day_of: Callable[[str], DayState]) -> list[Event]:
        """A worker's only stream: each run of clean blocks inside a running activity that says nothing (no dip, no
        limit, no prediction due) is counted in one step (:meth:`ActivityTracker.count_run`); the rest block by
        block."""
        events, bulk = [], not self.config.keep_timeline
        for blocks in runs:
            if bulk and not any(blocks.flags) and stream.tracker.count_run(blocks.seconds, blocks.energy, day_of):
                continue
            for end, _, device, seconds, energy, flags in _stream_blocks([blocks], stream):
                events += self._frame(stream, day_of, end, seconds, energy, flags)
        return events

    def _frame(self, stream: Stream, day_of: Callable[[str], DayState], end: float, seconds: float, energy: float,
               flags: int) -> list[Event]:
        tracker = stream.tracker
        if flags:
            tracker.reject(seconds)
            stream.count("rejected_s", seconds)
            return [self.event(stream, (ARTEFACT, end - seconds, {"seconds": seconds,
                                                                  "kinds": describe_flags(flags)}))]
        idle = tracker.state.id is None
        notices = tracker.frame(end, seconds, energy, day_of)
        if idle and tracker.state.id is None:  # vibration under the trigger: not exposure, but not nothing either
            stream.count("untriggered_s", seconds)
            stream.count("untriggered_energy", energy)
        if self.config.keep_timeline and tracker.state.id is not None:
            self.timeline.append((end, stream.session.subject, day_of(tracker.state.day).a8))
        return [self.event(stream, notice) for notice in notices] if notices else []

    def _day_lookup(self, subject: str) -> Callable[[str], DayState]:
        """The subject's worker-day by date (created and marked touched on first use); the last one is kept at hand,
        as a stream's blocks ask for the same day thousands of times."""
        last: list = [None, None]

        def day_of(day: str) -> DayState:
            if day == last[0]:
                return last[1]
            key = (subject, day)
            self.touched_days.add(key)
            state = self.days.get(key)
            if state is None:
                state = self.days[key] = DayState()
            last[:] = day, state
            return state

        return day_of

    # --- events --------------------------------------------------------------------------------------------
    def event(self, stream: Stream, notice: Notice) -> Event:
        """A tracker's notice as a bus event, with the session, the day's figures and the covered band."""
        kind, when, data = notice
        session, fs = stream.session, stream.buffer.fs
        coverage = covered_band(fs) if fs else None
        day = self.days.get((session.subject, data.get("day", utc_day(when))), DayState())
        body = {"site": self.config.site, "device": stream.device, "tool": session.tool,
                "position": session.position, "zone": session.zone, "estimate": session.estimate,
                "corrected": self.sessions.correction(session) is not None, "a_hv": stream.tracker.state.a_hv,
                "day_a8": day.a8, "day_points": day.points, "risk": day.risk,
                "band_hz": [coverage.low_hz, coverage.high_hz] if coverage else None,
                "band_limited": bool(coverage and not coverage.complete), "clock_offset_s": stream.clock.offset_s,
                "time_base": stream.time_base}
        body.update(data)
        return Event(kind, float(when), session.subject, stream.device, _finite(body), self.clock())

    def restore_stream(self, device: str, buffer: StreamBuffer, filter_state: FilterState,
                       activity: ActivityState, session: Session, clock_offset_s: float | None,
                       counters: dict[str, float]) -> Stream:
        """Put a stream saved before a restart back."""
        tracker = ActivityTracker(self.config.trigger, device, activity, session.hand)
        stream = Stream(device, buffer, filter_state, tracker, session, DeviceClock(clock_offset_s), counters)
        self.streams[device] = stream
        return stream


def _continues(piece: Piece, batch: AccelBatch) -> bool:
    """Whether ``batch`` extends ``piece``'s run: same rate and sensor range (the buffer already said it
    follows without a gap)."""
    last = piece.batches[-1]
    return batch.fs == last.fs and batch.full_scale == last.full_scale


def _stream_blocks(runs: list[Blocks], stream: Stream):
    """(end, order, device, seconds, energy, flags) of a stream's blocks, in its own order, their end times on the
    wall clock (:meth:`Stream.placed`)."""
    order, device = 0, stream.device
    for blocks in runs:
        shift = stream.clock.shift(blocks.end[0]) if blocks.end else 0.0
        ends = [end + shift for end in blocks.end] if shift else blocks.end
        for end, seconds, energy, flags in zip(ends, blocks.seconds, blocks.energy, blocks.flags):
            yield end, order, device, seconds, energy, flags
            order += 1


def _finite(body: dict) -> dict:
    """JSON has no inf/NaN: unbounded times become None."""
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in body.items()}
