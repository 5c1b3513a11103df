"""Counting a run of blocks in one step (ActivityTracker.count_run) gives exactly what block by block gives."""

from __future__ import annotations

import pytest

from bim2rdt.safety.activity import E_EAV, E_ELV, ActivityState, ActivityTracker, DayState
from bim2rdt.safety.config import Trigger

from hav_helpers import DAY, feed, plan_batches

PLAN = [("idle", 2), ("hammer_drill", 130), ("idle", 5), ("hammer_drill", 20), ("idle", 4)]
"""At 40 m/s^2 the first piece crosses EAV after ~112 s and predicts every 60 s; the dip ends the activity."""


@pytest.mark.parametrize("chunk", [1, 40])
def test_runs_counted_in_one_step_match_block_by_block_exactly(make_monitor, clock, chunk):
    items = plan_batches("dev-1", PLAN, fs=2500.0, a_hv={"hammer_drill": 40.0})
    outcomes = []
    for name, timeline in (("bulk", False), ("blocks", True)):  # a kept timeline makes the monitor go block by block
        monitor, sink = make_monitor(f"{name}-{chunk}", keep_timeline=timeline)
        subject = monitor.start_session("dev-1", "ola", "hammer_drill")
        feed(monitor, items, clock, chunk=chunk)
        day = monitor.queries.day(subject, DAY)
        outcomes.append(((day.energy, day.seconds, day.eav_at, day.elv_at),
                         [(e.kind, e.time, e.data) for e in sink.events]))
    assert outcomes[0] == outcomes[1]
    kinds = [kind for kind, _, _ in outcomes[0][1]]
    assert kinds.count("hav.eav_reached") == 1 and kinds.count("hav.eav_predicted") >= 2
    assert kinds.count("hav.activity_ended") == 2


def _running(day: DayState, energy_before: float) -> ActivityTracker:
    tracker = ActivityTracker(Trigger(), "dev-1", ActivityState(id="a", day=DAY, predicted_at_s=0.0))
    day.add("", energy_before, 100.0)
    return tracker


def test_a_run_that_would_cross_the_action_value_is_left_to_block_by_block():
    day = DayState()
    tracker = _running(day, E_EAV - 10.0)
    assert not tracker.count_run([0.5, 0.5], [8.0, 8.0], lambda _: day)  # 16 more: EAV is crossed inside
    assert day.energy == E_EAV - 10.0 and tracker.state.energy == 0.0  # nothing changed
    assert tracker.count_run([0.5], [8.0], lambda _: day)
    assert day.energy == E_EAV - 2.0 and tracker.state.seconds == 0.5


def test_a_run_with_a_dip_under_the_stop_threshold_is_left_to_block_by_block():
    day = DayState()
    tracker = _running(day, 0.0)
    assert not tracker.count_run([0.5, 0.5], [50.0, 0.01], lambda _: day)  # a_hv 0.14 m/s^2 in the second
    assert day.energy == 0.0


def test_a_run_that_would_cross_the_limit_value_is_left_to_block_by_block():
    day = DayState(eav_at=1.0)  # EAV reached earlier today: no prediction is due either
    tracker = _running(day, E_ELV - 10.0)
    assert not tracker.count_run([0.5, 0.5], [8.0, 8.0], lambda _: day)  # ELV is crossed inside
    assert day.energy == E_ELV - 10.0 and tracker.state.energy == 0.0
    assert tracker.count_run([0.5], [8.0], lambda _: day)


def test_a_limit_already_reached_does_not_stop_a_run_from_being_counted_in_one_step():
    day = DayState(eav_at=1.0, elv_at=2.0)  # both limits reached before (a restored day)
    tracker = _running(day, E_ELV - 10.0)
    assert tracker.count_run([0.5, 0.5], [8.0, 8.0], lambda _: day)
    assert day.energy == E_ELV + 6.0 and tracker.state.seconds == 1.0
