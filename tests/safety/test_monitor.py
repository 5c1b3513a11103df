"""HavMonitor: a working day, restarts, and what real streams do (duplicates, reordering, gaps, artefacts)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from bim2rdt.bus import AccelBatch, encode_accel
from bim2rdt.safety import HavError, combine_exposures, time_to_limit
from bim2rdt.safety.activity import E_EAV, E_ELV

from hav_helpers import DAY, T0, feed, main_kinds, plan_batches

# grinder 5 m/s^2 for 5 min, hammer drill 15 m/s^2 for 15 min (crosses EAV), breaker 25 m/s^2 for 15 min (ELV)
DAY_PLAN = [("idle", 10), ("grinder", 300), ("idle", 20), ("hammer_drill", 900), ("idle", 20), ("breaker", 900),
            ("idle", 10)]
DAY_AHV = {"grinder": 5.0, "hammer_drill": 15.0, "breaker": 25.0}
SHORT_PLAN = [("idle", 4), ("hammer_drill", 40), ("idle", 6)]


@pytest.fixture(scope="module")
def day_batches():
    return plan_batches("dev-1", DAY_PLAN, a_hv=DAY_AHV)


def test_a_day_with_three_tools_emits_start_eav_elv_and_end_events_in_order(make_monitor, clock, day_batches):
    monitor, sink = make_monitor()
    subject = monitor.start_session("dev-1", "alice", "multi", "handle", "zone-A")
    feed(monitor, day_batches, clock, chunk=60)
    assert main_kinds(sink) == ["hav.activity_started", "hav.activity_ended",
                                "hav.activity_started", "hav.eav_reached", "hav.activity_ended",
                                "hav.activity_started", "hav.elv_reached", "hav.activity_ended"]
    expected = combine_exposures([(DAY_AHV[t], s) for t, s in DAY_PLAN if t != "idle"])
    assert monitor.queries.day(subject, DAY).a8 == pytest.approx(expected, rel=0.01)
    # EAV: the grinder's energy, then (E_EAV - that) / 15^2 seconds into the hammer drill (starts at 330 s)
    eav = next(e for e in sink.events if e.kind == "hav.eav_reached")
    assert eav.time - T0 == pytest.approx(330 + (E_EAV - 25 * 300) / 15**2, abs=2.0)
    elv = next(e for e in sink.events if e.kind == "hav.elv_reached")
    assert elv.time - T0 == pytest.approx(1250 + (E_ELV - 25 * 300 - 225 * 900) / 25**2, abs=2.0)
    ended = [e for e in sink.events if e.kind == "hav.activity_ended"]
    assert [round(e.data["a_hv"], 1) for e in ended] == [5.0, 15.0, 25.0]
    assert [e.data["trigger_s"] for e in ended] == pytest.approx([300, 900, 900], abs=1.5)
    assert ended[-1].data["risk"] == "above_elv" and ended[-1].data["day_a8"] == pytest.approx(expected, rel=0.01)
    day = monitor.queries.day(subject, DAY)  # the day is exactly the sum of its activities: no block lost or counted twice
    assert day.seconds == pytest.approx(sum(e.data["trigger_s"] for e in ended), rel=1e-9)
    assert day.a8**2 == pytest.approx(sum(e.data["activity_a8"] ** 2 for e in ended), rel=1e-9)
    assert monitor.queries.days_of(subject) == [DAY]
    assert all(e.subject == subject and e.data["zone"] == "zone-A" for e in sink.events)


def test_the_first_prediction_matches_time_to_limit_at_the_tool_a_hv(make_monitor, clock):
    monitor, sink = make_monitor(predict_every_s=10.0)
    monitor.start_session("dev-1", "bob", "hammer_drill")
    feed(monitor, plan_batches("dev-1", SHORT_PLAN, a_hv={"hammer_drill": 10.0}), clock)
    predictions = [e for e in sink.events if e.kind == "hav.eav_predicted"]
    assert len(predictions) >= 2
    assert predictions[-1].data["seconds_to_eav"] == pytest.approx(time_to_limit(10.0) - 30, rel=0.03)


def test_a_restart_mid_shift_loses_nothing_and_double_counts_nothing(make_monitor, clock):
    items = plan_batches("dev-1", SHORT_PLAN * 2, batch_s=0.3)
    reference, ref_sink = make_monitor("uninterrupted")
    reference.start_session("dev-1", "carol", "hammer_drill")
    feed(reference, items, clock)
    ref_day = reference.queries.day(reference.queries.session("dev-1").subject, DAY)
    clock.now = T0

    first, first_sink = make_monitor()
    subject = first.start_session("dev-1", "carol", "hammer_drill")
    half = len(items) // 2 + 7  # mid-activity, mid-frame (0.3 s batches, 0.8 s frames)
    feed(first, items[:half], clock)
    first.close()  # the process dies here: no end_session, nothing flushed
    second, second_sink = make_monitor()
    feed(second, items[half - 5:], clock)  # QoS 1 redelivers the last five before the new ones
    day = second.queries.day(subject, DAY)
    assert day.energy == pytest.approx(ref_day.energy, rel=1e-6)
    assert day.seconds == pytest.approx(ref_day.seconds, rel=1e-9)
    assert main_kinds(first_sink) + main_kinds(second_sink) == main_kinds(ref_sink)
    assert second.queries.stats["duplicates"] == 5


def test_duplicates_and_out_of_order_batches_give_the_same_exposure(make_monitor, clock):
    items = plan_batches("dev-1", SHORT_PLAN)
    ordered, _ = make_monitor("ordered")
    subject = ordered.start_session("dev-1", "dan", "hammer_drill")
    feed(ordered, items, clock)
    messy = _shuffle_with_duplicates(items, np.random.default_rng(3))
    monitor, _ = make_monitor("messy")
    monitor.start_session("dev-1", "dan", "hammer_drill")
    for batch in messy:
        monitor.ingest_many([batch], now=batch.device_time + 1.0)
    assert monitor.queries.day(subject, DAY).energy == pytest.approx(ordered.queries.day(subject, DAY).energy, rel=1e-6)
    assert monitor.queries.stats["duplicates"] == len(messy) - len(items)
    assert monitor.queries.stats.get("gaps", 0) == 0


def _shuffle_with_duplicates(items, rng):
    out = []
    for start in range(0, len(items), 4):
        window = items[start:start + 4]
        out += [window[i] for i in rng.permutation(len(window))]
    for i in rng.choice(len(items), size=len(items) // 10, replace=False):
        out.insert(min(len(out), int(i) + 3), items[int(i)])
    return out


def test_missing_batches_are_a_reported_gap_and_not_counted_as_exposure(make_monitor, clock):
    items = plan_batches("dev-1", SHORT_PLAN)
    monitor, sink = make_monitor()
    monitor.start_session("dev-1", "erin", "hammer_drill")
    feed(monitor, items[:40] + items[43:], clock)  # 3 batches of 0.5 s lost mid-activity
    gaps = [e for e in sink.events if e.kind == "hav.gap"]
    assert len(gaps) == 1
    assert gaps[0].data["missing_batches"] == 3 and gaps[0].data["seconds"] == pytest.approx(1.5)
    ended = [e for e in sink.events if e.kind == "hav.activity_ended"]
    assert len(ended) == 1  # the gap does not split the activity
    assert ended[0].data["trigger_s"] == pytest.approx(40 - 1.5, abs=1.0)
    assert ended[0].data["gap_s"] == pytest.approx(1.5)


def test_a_pause_in_device_time_is_a_gap(make_monitor, clock):
    items = plan_batches("dev-1", SHORT_PLAN)
    shifted = items[:40] + [dataclasses.replace(b, device_time=b.device_time + 30.0) for b in items[40:]]
    monitor, sink = make_monitor()
    monitor.start_session("dev-1", "fay", "hammer_drill")
    feed(monitor, shifted, clock)
    gap = next(e for e in sink.events if e.kind == "hav.gap")
    assert gap.data["reason"] == "device time jump" and gap.data["seconds"] == pytest.approx(30.0)


@pytest.mark.parametrize("kind", ["nan", "saturation", "shock"])
def test_artefacts_are_rejected_and_flagged(make_monitor, clock, kind):
    items = plan_batches("dev-1", SHORT_PLAN)
    clean, _ = make_monitor("clean")
    subject = clean.start_session("dev-1", "gus", "hammer_drill")
    feed(clean, items, clock)
    clean_energy = clean.queries.day(subject, DAY).energy
    spoiled = [dataclasses.replace(b, xyz=_spoil(b.xyz, kind, b.full_scale)) if i == 50 else b
               for i, b in enumerate(items)]
    clock.now = T0
    monitor, sink = make_monitor("spoiled")
    monitor.start_session("dev-1", "gus", "hammer_drill")
    feed(monitor, spoiled, clock)
    sink_events = sink.events
    flagged = [e for e in sink_events if e.kind == "hav.artefact"]
    assert flagged[0].data["kinds"] == [kind]
    assert flagged[-1].data["kinds"] == ["settling"]  # the block after, while the filter rings down
    day = monitor.queries.day(subject, DAY)
    assert np.isfinite(day.energy) and day.energy < clean_energy  # rejected frames do not count
    assert day.energy > 0.9 * clean_energy  # ... and only those
    ended = next(e for e in sink_events if e.kind == "hav.activity_ended")
    assert ended.data["rejected_s"] > 0


def _spoil(xyz, kind, full_scale):
    xyz = xyz.copy()
    if kind == "nan":
        xyz[100:110, 0] = np.nan
    elif kind == "saturation":
        xyz[100:400, 0] = full_scale
    else:
        xyz[100, :] += 1500.0  # a knock: far above the tool, below the sensor range
    return xyz


def test_device_and_receive_times_are_both_kept_under_clock_skew(make_monitor, clock):
    items = plan_batches("dev-1", SHORT_PLAN)
    monitor, sink = make_monitor()
    monitor.start_session("dev-1", "hal", "hammer_drill")
    for i in range(0, len(items), 10):  # the device clock runs 42 s behind ours
        clock.now = items[i + 9].device_time + 0.5 + 42.0 + 0.1
        monitor.ingest_many(items[i:i + 10])
    started = next(e for e in sink.events if e.kind == "hav.activity_started")
    assert started.time - T0 == pytest.approx(4.0, abs=1.0)  # the device's time base
    assert started.received - started.time > 40.0  # our clock
    assert started.data["clock_offset_s"] == pytest.approx(42.1, abs=2.5)


def test_a_low_rate_sensor_is_flagged_with_the_band_it_covers(make_monitor, clock):
    monitor, sink = make_monitor()
    monitor.start_session("watch-1", "ivy", "grinder", position="wrist")
    feed(monitor, plan_batches("watch-1", [("idle", 3), ("grinder", 20)], fs=800.0), clock)
    started = next(e for e in sink.events if e.kind == "hav.activity_started")
    assert started.data["band_limited"] is True
    assert started.data["band_hz"][1] == pytest.approx(316.23, abs=0.01)
    assert started.data["estimate"] is True and started.data["corrected"] is False


def test_ending_a_session_ends_the_running_activity_with_the_day_exposure(make_monitor, clock):
    monitor, sink = make_monitor()
    subject = monitor.start_session("dev-1", "jo", "breaker")
    feed(monitor, plan_batches("dev-1", [("idle", 2), ("breaker", 30)]), clock)
    assert monitor.queries.activity("dev-1").id is not None
    clock.now += 300.0  # the offline status (last will) reaches us five minutes after the last sample
    events = monitor.end_session("dev-1")
    assert [e.kind for e in events][-1] == "hav.activity_ended"
    assert events[-1].time - T0 == events[-1].data["ended"] - T0 == pytest.approx(32.0, abs=1e-6)  # device time, last sample
    assert events[-1].data["day_a8"] == pytest.approx(monitor.queries.day(subject, DAY).a8)
    assert monitor.store.activities(subject)[-1]["open"] is False


def test_with_both_hands_exposed_the_day_counts_the_greater_hand(make_monitor, clock):
    monitor, sink = make_monitor()
    subject = monitor.start_session("left-1", "pat", "grinder", hand="left")
    monitor.start_session("right-1", "pat", "breaker", hand="right")
    left = plan_batches("left-1", [("idle", 2), ("grinder", 60)], a_hv={"grinder": 5.0}, seed=1)
    right = plan_batches("right-1", [("idle", 2), ("breaker", 60)], a_hv={"breaker": 12.0}, seed=2)
    feed(monitor, [b for pair in zip(left, right) for b in pair], clock)
    day = monitor.queries.day(subject, DAY)
    assert day.a8 == pytest.approx(combine_exposures([(12.0, 60.0)]), rel=0.02)  # not the sum of both hands
    assert set(day.hands) == {"left", "right"}
    assert day.hand_energy("left") == pytest.approx(25.0 * 60, rel=0.03)


def test_a_batch_at_a_rate_below_every_wh_band_is_counted_and_ignored_not_fatal(make_monitor, clock):
    monitor, sink = make_monitor()
    slow = AccelBatch("dev-1", 0, T0, 10.0, np.ones((20, 3), np.float32))  # 10 Hz: Nyquist below the 8 Hz band
    assert monitor.ingest_payload("site/demo/wearable/dev-1/accel", encode_accel(slow)) == []
    assert monitor.queries.stats["malformed"] == 1
    with pytest.raises(HavError, match="10 Hz"):
        monitor.ingest(slow)
    feed(monitor, plan_batches("dev-1", SHORT_PLAN), clock)  # the stream itself is untouched and still works
    assert "hav.activity_started" in sink.kinds()
