"""A device clock that is no wall time (counting from boot) files exposure on the day it was taken, not 1970."""

from __future__ import annotations

import dataclasses

import pytest

from bim2rdt.safety.clock import WALL_CLOCK_FROM, DeviceClock

from hav_helpers import DAY, T0, plan_batches

PLAN = [("idle", 2), ("hammer_drill", 30), ("idle", 4)]
UPTIME = 3600.25
"""The boot clock's reading when the shift starts at T0: the wearable was switched on an hour before."""
DELAY = 0.04
"""Delivery delay of every batch, seconds."""


@pytest.fixture(scope="module")
def items():
    return plan_batches("dev-1", PLAN, a_hv={"hammer_drill": 8.0})


def _boot_clock(items):
    """The same batches stamped by a clock counting seconds since power-up."""
    return [dataclasses.replace(b, device_time=b.device_time - T0 + UPTIME) for b in items]


def _ingest(monitor, batches, skew: float):
    """One batch at a time, each received ``DELAY`` after its last sample on a receive clock ``skew`` ahead."""
    for batch in batches:
        monitor.ingest_many([batch], now=batch.device_time + batch.duration_s + skew + DELAY)


def _run(make_monitor, name, batches, skew):
    monitor, sink = make_monitor(name)
    subject = monitor.start_session("dev-1", "kai", "hammer_drill")
    _ingest(monitor, batches, skew)
    return monitor, sink, subject


def test_a_clock_counting_from_boot_files_the_exposure_on_the_day_it_was_received(make_monitor, items):
    wall, wall_sink, subject = _run(make_monitor, "wall", items, skew=0.0)
    boot, boot_sink, _ = _run(make_monitor, "boot", _boot_clock(items), skew=T0 - UPTIME)
    assert boot.queries.days_of(subject) == [DAY]  # not 1970-01-01
    assert boot.queries.day(subject, DAY).energy == pytest.approx(wall.queries.day(subject, DAY).energy, rel=1e-12)
    assert boot.queries.day(subject, DAY).seconds == pytest.approx(wall.queries.day(subject, DAY).seconds)
    assert [e.kind for e in boot_sink.events] == [e.kind for e in wall_sink.events]
    for placed, true in zip(boot_sink.events, wall_sink.events):  # on the receive clock: late by the delay only
        assert placed.time - true.time == pytest.approx(DELAY, abs=1e-6)
        assert placed.data["time_base"] == "receive" and true.data["time_base"] == "device"
    ended = next(e for e in boot_sink.events if e.kind == "hav.activity_ended")
    assert ended.data["started"] - T0 == pytest.approx(2.0 + DELAY, abs=0.51)
    assert boot.queries.stream_status("dev-1")["time_base"] == "receive"


def test_a_wall_clock_device_keeps_its_own_times_however_late_it_arrives(make_monitor, items):
    monitor, sink, subject = _run(make_monitor, "late", items, skew=90_000.0)  # the next day at our end
    assert monitor.queries.days_of(subject) == [DAY]
    started = next(e for e in sink.events if e.kind == "hav.activity_started")
    assert started.time - T0 == pytest.approx(2.0, abs=0.51) and started.data["time_base"] == "device"


def test_a_monitor_restart_on_a_boot_clock_loses_nothing_and_counts_nothing_twice(make_monitor, items):
    wall, _, subject = _run(make_monitor, "wall", items, skew=0.0)
    stream = _boot_clock(items)
    for cut in (10, 40):  # before the tool starts, and mid-activity
        first, _ = make_monitor(f"cut-{cut}")
        first.start_session("dev-1", "kai", "hammer_drill")
        _ingest(first, stream[:cut], skew=T0 - UPTIME)
        first.close()  # the process dies; QoS 1 redelivers the last four, late
        second, _ = make_monitor(f"cut-{cut}")
        _ingest(second, stream[cut - 4:cut], skew=T0 - UPTIME + 30.0)
        _ingest(second, stream[cut:], skew=T0 - UPTIME)
        assert second.queries.days_of(subject) == [DAY], cut
        assert second.queries.day(subject, DAY).energy == pytest.approx(wall.queries.day(subject, DAY).energy, rel=1e-12), cut
        assert second.queries.stats["duplicates"] == 4, cut


def test_a_boot_clock_device_that_restarts_starts_over_on_the_receive_clock(make_monitor, items):
    """After a restart the boot clock reads from 0 again: the new epoch gets its own offset, and both halves land on
    the real day."""
    stream = _boot_clock(items)
    reboot = 40
    restarted = stream[:reboot] + [dataclasses.replace(b, seq=b.seq - reboot,
                                                       device_time=b.device_time - stream[reboot].device_time + 0.5)
                                   for b in stream[reboot:]]
    monitor, sink = make_monitor()
    subject = monitor.start_session("dev-1", "kai", "hammer_drill")
    _ingest(monitor, restarted[:reboot], skew=T0 - UPTIME)
    _ingest(monitor, restarted[reboot:], skew=stream[reboot].device_time - 0.5 + T0 - UPTIME)
    assert monitor.queries.days_of(subject) == [DAY] and monitor.queries.stream_status("dev-1")["restarts"] == 1
    assert monitor.queries.day(subject, DAY).seconds == pytest.approx(30.0, abs=0.6)
    assert all(0.0 <= e.time - T0 < 40.0 for e in sink.events)  # on the shift's clock, both epochs


def test_an_offline_boot_clock_device_ends_its_activity_at_its_last_sample_on_the_receive_clock(make_monitor, items):
    stream = _boot_clock(items)
    monitor, sink = make_monitor()
    monitor.start_session("dev-1", "kai", "hammer_drill")
    _ingest(monitor, stream[:20] + stream[30:50], skew=T0 - UPTIME)  # five seconds lost on the way: a gap
    monitor.tick(now=T0 + 60.0)
    events = monitor.end_session("dev-1")  # its last will, long after
    assert events[-1].kind == "hav.activity_ended"
    assert events[-1].time - T0 == pytest.approx(25.0 + DELAY, abs=1e-6)
    gap = next(e for e in sink.events if e.kind == "hav.gap")
    assert (gap.time - T0, gap.data["end"] - T0) == (pytest.approx(10.0 + DELAY, abs=1e-6),
                                                     pytest.approx(15.0 + DELAY, abs=1e-6))


@pytest.mark.parametrize("device_time, offset, shift", [
    (T0, 5.0, 0.0),                          # wall time: kept
    (120.0, None, 0.0),                      # nothing known yet
    (120.0, T0 - 120.0, T0 - 120.0),         # boot clock, receive clock on wall time: placed there
    (120.0, -100.0, 0.0),                    # boot clock, receive clock not on wall time either (hav analyze)
    (WALL_CLOCK_FROM - 1.0, 10.0, 10.0),     # a real-time clock a second short of 2020: placed
])
def test_a_device_time_moves_onto_the_wall_clock_only_when_it_is_none_and_the_offset_gives_one(device_time, offset,
                                                                                                shift):
    assert DeviceClock(offset).shift(device_time) == shift


def test_a_clock_reset_within_one_boot_files_the_rest_of_the_shift_on_the_receive_clock(make_monitor):
    """60 batches on wall time, then the same boot with device time restarting from 0 (its real-time clock lost
    its setting): the 90 s after the reset count on the day they were received, as after a reboot."""
    items = plan_batches("dev-1", [("idle", 30), ("grinder", 90), ("idle", 5)], a_hv={"grinder": 8.0})
    control, _ = make_monitor("control")
    reset, reset_sink = make_monitor("reset")
    subject = control.start_session("dev-1", "kai", "grinder")
    reset.start_session("dev-1", "kai", "grinder")
    for monitor in (control, reset):
        monitor.announce_boot("dev-1", "boot-1")
    for k, batch in enumerate(items):
        received = batch.device_time + batch.duration_s + DELAY
        control.ingest_many([batch], now=received)
        sent = batch if k < 60 else dataclasses.replace(batch, device_time=(k - 60) * batch.duration_s)
        reset.ingest_many([sent], now=received)
    assert reset.queries.days_of(subject) == control.queries.days_of(subject) == [DAY]  # before: 90 s on 1970-01-01
    # the same A(8) to the displayed 0.01 m/s^2 (0.447 against 0.448): the jump starts a segment whose weighting
    # filter restarts settled, as after a reboot, so the first half-second of grinding is weighed afresh
    assert reset.queries.day(subject, DAY).a8 == pytest.approx(control.queries.day(subject, DAY).a8, rel=5e-3)
    assert reset.queries.day(subject, DAY).seconds == pytest.approx(control.queries.day(subject, DAY).seconds, abs=0.5)
    assert all(e.time >= T0 for e in reset_sink.events)
    assert reset.queries.stream_status("dev-1")["time_base"] == "receive"
