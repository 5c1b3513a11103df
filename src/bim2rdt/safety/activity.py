"""Trigger-time activity detection and daily exposure accounting, one analysis frame at a time.

Like an ISO 8041-2 personal vibration exposure meter, exposure time is *trigger time*: a frame whose a_hv is at
least ``start_threshold`` starts an activity (a tool is running); the activity ends once frames stay below
``stop_threshold`` for ``stop_hold_s`` seconds, and that trailing quiet time is not counted. Short dips inside an
activity are counted. Energy is the currency: sum(a_hv^2 dt) in m^2/s^3 adds across frames, activities and tools,
and A(8) = sqrt(energy / 8 h), so EAV is crossed at 2.5^2 * 8 h of energy and ELV at 5^2 * 8 h.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from bim2rdt.safety.config import Trigger
from bim2rdt.safety.exposure import EAV, ELV, T0_S, a8_from_energy, points_from_energy

ACTIVITY_STARTED = "hav.activity_started"
EAV_PREDICTED = "hav.eav_predicted"
EAV_REACHED = "hav.eav_reached"
ELV_REACHED = "hav.elv_reached"
ACTIVITY_ENDED = "hav.activity_ended"
GAP = "hav.gap"
ARTEFACT = "hav.artefact"
E_EAV = EAV**2 * T0_S
E_ELV = ELV**2 * T0_S
_LIMITS = ((EAV_REACHED, E_EAV, "eav_at", EAV), (ELV_REACHED, E_ELV, "elv_at", ELV))

Notice = tuple[str, float, dict]
"""(event kind, device time, data) produced by the tracker; the monitor turns it into an Event."""


@dataclass
class DayState:
    """One worker's day: accumulated weighted energy (m^2/s^3) and trigger time (s) per hand, when EAV/ELV were
    reached. With both hands exposed ISO 5349-1 takes the greater: the day's energy is the larger hand's (a
    wearable whose hand is not given counts as hand '', so two such devices on one worker add up)."""

    hands: dict[str, list[float]] = field(default_factory=dict)
    eav_at: float | None = None
    elv_at: float | None = None

    def __post_init__(self) -> None:
        self._greater = max(self.hands.values(), default=[0.0, 0.0])

    @property
    def energy(self) -> float:
        """The greater hand's accumulated energy, m^2/s^3."""
        return self._greater[0]

    @property
    def seconds(self) -> float:
        """The greater hand's trigger time, s."""
        return self._greater[1]

    def hand_energy(self, hand: str) -> float:
        return self.hands.get(hand, (0.0, 0.0))[0]

    def add(self, hand: str, energy: float, seconds: float) -> None:
        record = self.hands.get(hand)
        if record is None:
            record = self.hands[hand] = [0.0, 0.0]
        record[0] += energy
        record[1] += seconds
        if record[0] >= self._greater[0]:
            self._greater = record

    def hand_totals(self, hand: str) -> tuple[float, float]:
        """(energy, seconds) of one hand so far."""
        record = self.hands.get(hand)
        return (record[0], record[1]) if record is not None else (0.0, 0.0)

    def set_hand_totals(self, hand: str, energy: float, seconds: float) -> None:
        """Put one hand's totals, summed block by block elsewhere (never lower than they were)."""
        record = self.hands.get(hand)
        if record is None:
            record = self.hands[hand] = [0.0, 0.0]
        record[0], record[1] = energy, seconds
        if record[0] >= self._greater[0]:
            self._greater = record

    @property
    def a8(self) -> float:
        return a8_from_energy(self.energy)

    @property
    def points(self) -> float:
        return points_from_energy(self.energy)

    @property
    def risk(self) -> str:
        return "above_elv" if self.energy >= E_ELV else "above_eav" if self.energy >= E_EAV else "below_eav"


@dataclass
class ActivityState:
    """The activity running on one stream (``id`` None when idle)."""

    id: str | None = None
    day: str = ""
    started: float = 0.0
    energy: float = 0.0
    seconds: float = 0.0
    low_energy: float = 0.0
    low_seconds: float = 0.0
    low_since: float | None = None
    rejected_s: float = 0.0
    gap_s: float = 0.0
    predicted_at_s: float | None = None

    @property
    def a_hv(self) -> float:
        return math.sqrt(self.energy / self.seconds) if self.seconds > 0 else 0.0

    def to_dict(self) -> dict:
        return dict(vars(self))

    def to_list(self) -> list:
        """The fields in declaration order (``ActivityState(*values)`` rebuilds it)."""
        return list(vars(self).values())


DayLookup = Callable[[str], DayState]


class ActivityTracker:
    """Feeds one stream's frames through activity detection into the worker's day; ``name`` (the device)
    prefixes activity ids."""

    __slots__ = ("trigger", "name", "hand", "state")

    def __init__(self, trigger: Trigger, name: str, state: ActivityState | None = None, hand: str = ""):
        self.trigger, self.name, self.hand = trigger, name, hand
        self.state = state or ActivityState()

    def frame(self, end: float, seconds: float, energy: float, day_of: DayLookup) -> list[Notice]:
        """Account one clean block covering ``seconds`` of samples up to device time ``end``."""
        act, notices = self.state, []
        level = math.sqrt(energy / seconds) if seconds > 0 else 0.0
        if act.id is None:
            if level < self.trigger.start_threshold:
                return notices
            notices += self._start(end - seconds, utc_day(end - seconds))
            act = self.state
        if level < self.trigger.stop_threshold:
            act.low_energy, act.low_seconds = act.low_energy + energy, act.low_seconds + seconds
            act.low_since = act.low_since if act.low_since is not None else end - seconds
            if act.low_seconds >= self.trigger.stop_hold_s:
                notices += self.stop(act.low_since, day_of)
            return notices
        if act.low_seconds:  # a dip inside the activity counts
            energy, seconds = energy + act.low_energy, seconds + act.low_seconds
            act.low_energy, act.low_seconds, act.low_since = 0.0, 0.0, None
        counted = self._count(end, seconds, energy, day_of(act.day))
        return notices + counted if notices else counted

    def count_run(self, seconds: Sequence[float], energies: Sequence[float], day_of: DayLookup) -> bool:
        """Count a run of clean blocks in one step where :meth:`frame` would say nothing about any of them: an
        activity runs, no block dips under the stop threshold, no limit is crossed and no prediction falls due.
        The sums are :meth:`frame`'s (the same additions in the same order). False, with nothing changed, when a
        block needs :meth:`frame`."""
        act = self.state
        if act.id is None or act.low_seconds:
            return False
        stop = self.trigger.stop_threshold
        day = day_of(act.day)
        act_energy, act_seconds = act.energy, act.seconds
        hand_energy, hand_seconds = day.hand_totals(self.hand)
        for block_s, energy in zip(seconds, energies):
            if (math.sqrt(energy / block_s) if block_s > 0 else 0.0) < stop:
                return False
            act_energy, act_seconds = act_energy + energy, act_seconds + block_s
            hand_energy, hand_seconds = hand_energy + energy, hand_seconds + block_s
        before, after = day.energy, max(day.energy, hand_energy)
        if (before < E_EAV <= after and day.eav_at is None) or (before < E_ELV <= after and day.elv_at is None):
            return False  # a limit crossed (the two of _LIMITS, spelled out: this runs for every stream and round)
        last = act.predicted_at_s
        if day.eav_at is None and (last is None or act_seconds - last >= self.trigger.predict_every_s):
            return False
        act.energy, act.seconds = act_energy, act_seconds
        day.set_hand_totals(self.hand, hand_energy, hand_seconds)
        return True

    def reject(self, seconds: float) -> None:
        """A frame rejected as an artefact: not exposure, but remembered against the activity."""
        if self.state.id is not None:
            self.state.rejected_s += seconds

    def gap(self, seconds: float) -> None:
        if self.state.id is not None:
            self.state.gap_s += seconds

    def stop(self, when: float, day_of: DayLookup) -> list[Notice]:
        """End the running activity at device time ``when`` (quiet, tool change, device offline)."""
        act = self.state
        if act.id is None:
            return []
        day = day_of(act.day)
        data = {"activity": act.id, "day": act.day, "started": act.started, "ended": when, "a_hv": act.a_hv,
                "trigger_s": act.seconds, "rejected_s": act.rejected_s, "gap_s": act.gap_s,
                "activity_a8": a8_from_energy(act.energy), "activity_points": points_from_energy(act.energy),
                "day_a8": day.a8, "day_points": day.points, "risk": day.risk}
        self.state = ActivityState()
        return [(ACTIVITY_ENDED, when, data)]

    def _start(self, when: float, day_key: str) -> list[Notice]:
        self.state = ActivityState(id=f"{self.name}@{when:.3f}", day=day_key, started=when)
        return [(ACTIVITY_STARTED, when, {"activity": self.state.id, "day": day_key})]

    def _count(self, end: float, seconds: float, energy: float, day: DayState) -> list[Notice]:
        act, notices = self.state, []
        before = day.energy
        act.energy, act.seconds = act.energy + energy, act.seconds + seconds
        day.add(self.hand, energy, seconds)
        after = day.energy
        for kind, limit, attr, value in _LIMITS if before < E_ELV <= after or before < E_EAV <= after else ():
            if before < limit <= after and getattr(day, attr) is None:
                when = end - seconds + seconds * (limit - before) / (after - before)
                setattr(day, attr, when)
                notices.append((kind, when, {"activity": act.id, "day": act.day, "limit": value,
                                             "day_a8": math.sqrt(limit / T0_S), "day_points": points_from_energy(limit)}))
        if day.eav_at is None and self._prediction_due():
            notices.append(self._predict(end, day))
        return notices

    def _prediction_due(self) -> bool:
        last = self.state.predicted_at_s
        return last is None or self.state.seconds - last >= self.trigger.predict_every_s

    def _predict(self, end: float, day: DayState) -> Notice:
        act = self.state
        act.predicted_at_s = act.seconds
        rate = act.a_hv**2
        own = day.hand_energy(self.hand)  # this hand's way to the limit (the other hand's stream predicts its own)
        to_eav = (E_EAV - own) / rate if rate > 0 else math.inf
        to_elv = (E_ELV - own) / rate if rate > 0 else math.inf
        return (EAV_PREDICTED, end, {"activity": act.id, "day": act.day, "seconds_to_eav": to_eav,
                                     "eav_expected_at": end + to_eav, "seconds_to_elv": to_elv})


def utc_day(when: float) -> str:
    """The UTC date ('YYYY-MM-DD') of device time ``when``: the day an activity's exposure counts towards."""
    return time.strftime("%Y-%m-%d", time.gmtime(when))
