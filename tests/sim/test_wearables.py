"""Simulated wearables announce their boot, and a simulated restart exercises the monitor's reboot handling."""

from __future__ import annotations

import json
import time

import pytest

from bim2rdt.bus.payloads import decode_accel, decode_status
from bim2rdt.safety import HavMonitor, ListSink, MonitorConfig
from bim2rdt.safety.activity import utc_day
from bim2rdt.sim.wearables import REBOOT, WorkerPlan, run_in_process, timed_messages, with_reboot

T0 = 1_700_000_000.0
FS = 1000.0
PLAN = WorkerPlan("w1", "worker-001", None, (("idle", 2.0), ("hammer_drill", 40.0), ("idle", 4.0)))
TOOL_S = 40.0


def _messages(plan):
    """(wall time, kind, decoded) of a plan's messages."""
    out = []
    for when, _, topic, payload, _ in timed_messages([plan], "s", FS, T0):
        kind = topic.rsplit("/", 1)[1]
        out.append((when, kind, decode_accel(payload) if kind == "accel" else decode_status(payload)))
    return out


def test_a_reboot_splits_the_running_piece_and_keeps_the_plan_s_work():
    plan = with_reboot(PLAN, 20.0, down_s=7.0)
    assert plan.pieces == (("idle", 2.0), ("hammer_drill", 18.0), (REBOOT, 7.0), ("hammer_drill", 22.0), ("idle", 4.0))


def test_every_online_status_names_the_boot_and_a_restart_draws_a_new_one():
    messages = _messages(with_reboot(PLAN, 20.0))
    statuses = [(when, m) for when, kind, m in messages if kind == "status"]
    online = [m.boot for _, m in statuses if m.online]
    assert None not in online and len(set(online)) == 2  # one boot, then the other after the restart
    offline = [when for when, m in statuses if not m.online]
    assert len(offline) == 2 and offline[0] == pytest.approx(T0 + 20.0)  # the last will, then the day's end
    after = [m for when, kind, m in messages if kind == "accel" and when > offline[0]]
    assert after[0].seq == 0 and after[0].device_time == pytest.approx(T0 + 30.0)  # wall clock: time goes on


def test_a_boot_clock_counts_from_power_up_and_starts_over_after_a_restart():
    messages = _messages(with_reboot(WorkerPlan(**{**vars(PLAN), "clock": "boot"}), 20.0))
    accel = [(when, m) for when, kind, m in messages if kind == "accel"]
    assert accel[0][1].device_time == 0.0 and accel[0][0] == T0
    restarted = next(i for i, (_, m) in enumerate(accel) if i and m.seq == 0)
    assert accel[restarted][1].device_time == 0.0 and accel[restarted][0] == pytest.approx(T0 + 30.0)
    assert [m.device_time for _, m in accel[restarted:restarted + 5]] == [m.device_time for _, m in accel[:5]]


def _simulate(tmp_path, plan, strip_boot: bool = False):
    """Run ``plan`` through the in-process bus into a fresh monitor; ``strip_boot`` drops the boot ids on the way."""
    monitor = HavMonitor(tmp_path / ("stripped" if strip_boot else "kept"), "test", [ListSink()], MonitorConfig(site="s"))
    if strip_boot:
        original = monitor.on_status
        monitor.on_status = lambda topic, payload: original(topic, _without_boot(payload))
    started = time.time()
    run_in_process([plan], monitor, "s", FS)
    subject = monitor.queries.session("w1").subject
    days = monitor.queries.days_of(subject)
    assert set(days) <= {utc_day(started), utc_day(time.time())}  # the day it ran (never 1970-01-01)
    result = days, monitor.queries.day(subject, days[-1]).seconds, monitor.queries.stream_status("w1")
    monitor.close()
    return result


def _without_boot(payload: bytes) -> bytes:
    body = json.loads(payload)
    body.pop("boot", None)
    return json.dumps(body).encode()


def test_a_simulated_restart_on_a_boot_clock_loses_no_exposure_because_the_boot_id_says_so(tmp_path):
    """After the restart the boot clock repeats the first power-up's times exactly: the new boot id in the status is
    what makes the monitor count them; stripped of it, the monitor takes them for replays (never double-counts)."""
    plan = with_reboot(WorkerPlan(**{**vars(PLAN), "clock": "boot"}), 20.0)
    _, seconds, status = _simulate(tmp_path, plan)
    assert seconds == pytest.approx(TOOL_S, abs=1.5)
    assert status["restarts"] == 1 and status.get("duplicates", 0) == 0 and status["time_base"] == "receive"
    _, stripped_seconds, stripped = _simulate(tmp_path, plan, strip_boot=True)
    assert stripped["duplicates"] > 10 and stripped_seconds < seconds - 5.0


def test_a_simulated_restart_on_a_wall_clock_loses_no_exposure(tmp_path):
    _, seconds, status = _simulate(tmp_path, with_reboot(PLAN, 20.0))
    assert seconds == pytest.approx(TOOL_S, abs=1.5)
    assert status.get("duplicates", 0) == 0 and status["renumbered"] + status.get("restarts", 0) >= 1
    assert status["time_base"] == "device"
