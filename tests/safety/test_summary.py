"""On-device summaries (1 Hz per-axis Wh r.m.s.) as a stream type: the same A(8) as the raw stream, told apart
per device, de-duplicated across restarts, malformed ones dead-lettered."""

from __future__ import annotations

import time

import numpy as np
import pytest

from bim2rdt.bus.local import LocalBus
from bim2rdt.bus.summaries import DeviceSummary, decode_summary, encode_summary, summary_topic
from bim2rdt.safety import HavMonitor, MonitorConfig
from bim2rdt.safety.summary import SummaryDevice
from bim2rdt.safety.weighting import weighted_rms
from bim2rdt.sim.vibration import ToolSignal
from bim2rdt.sim.wearables import default_plans, run_in_process

FS = 2500.0
SECRET = "summary-test"


def day_figures(monitor, devices) -> dict:
    out = {}
    for device in devices:
        subject = monitor.queries.session(device).subject
        for day in monitor.queries.days_of(subject):
            state = monitor.queries.day(subject, day)
            out[(device, day)] = (state.a8, state.seconds)
    return out


def test_a8_from_summaries_equals_a8_from_the_raw_stream_within_one_percent_on_simulated_days():
    plans = default_plans(3, 9.0)  # three workers, three tools each, 2.5 min per tool
    devices = [p.device for p in plans]
    raw, summary = (HavMonitor(None, SECRET, config=MonitorConfig()) for _ in range(2))
    t0 = time.time()
    run_in_process(plans, raw, "demo", FS)
    run_in_process(plans, summary, "demo", FS, summaries=True)
    want, got = day_figures(raw, devices), day_figures(summary, devices)
    assert want.keys() == got.keys() and len(want) == 3
    for key, (a8, seconds) in want.items():
        assert a8 > 1.0 and seconds > 300
        assert got[key][0] == pytest.approx(a8, rel=0.01), key
    assert {raw.queries.stream_status(d)["stream"] for d in devices} == {"raw"}
    assert {summary.queries.stream_status(d)["stream"] for d in devices} == {"summary"}
    assert all(summary.queries.stream_status(d)["summaries"] > 400 for d in devices)


def test_a_device_summary_is_the_per_axis_weighted_rms_of_its_second():
    signal = ToolSignal("grinder", 3.0, FS, 4.0, seed=3).samples()
    device = SummaryDevice("w1", FS)
    seconds = device.feed(signal[:4000], 100.0) + device.feed(signal[4000:], 100.0 + 4000 / FS)
    assert [s.seq for s in seconds] == [0, 1, 2] and [s.device_time for s in seconds] == [100.0, 101.0, 102.0]
    per = int(FS)
    for k, summary in enumerate(seconds[1:], start=1):  # past the first second the filter has settled
        for axis in range(3):
            want = weighted_rms(signal[k * per:(k + 1) * per, axis].astype(np.float64), FS)
            assert summary.ahw[axis] == pytest.approx(want, rel=0.05)


def test_a_summary_is_about_200_bytes_and_round_trips():
    summary = DeviceSummary("w1", 12, 1_700_000_000.25, 1.0, 5000.0, (1.234567, 2.5, 0.1), (80.5, 120.25, 33.0),
                            False, 1961.33)
    payload = encode_summary(summary)
    assert len(payload) <= 200
    assert decode_summary(payload) == summary


def test_redelivered_summaries_count_once_even_after_a_restart_and_a_skipped_one_is_a_gap(tmp_path):
    signal = ToolSignal("hammer_drill", 20.0, FS, 8.0, seed=1).samples()
    summaries = SummaryDevice("w1", FS).feed(signal, time.time() - 30)
    monitor = HavMonitor(tmp_path, SECRET)
    subject = monitor.start_session("w1", "ann", "hammer_drill")
    monitor.ingest_many(summaries[:12])
    monitor.close()
    monitor = HavMonitor(tmp_path, SECRET)  # restored: the summary seq and end come back with the stream
    monitor.ingest_many(summaries[:15])  # 12 again (redelivered), 3 new
    monitor.ingest_many(summaries[16:])  # one missing
    day = monitor.queries.days_of(subject)[0]
    status = monitor.queries.stream_status("w1")
    assert status["summaries"] == 19 and status["duplicates"] == 12 and status["summary_gap_s"] == 1.0
    reference = HavMonitor(None, SECRET)
    reference.start_session("w1", "ann", "hammer_drill")
    reference.ingest_many(summaries[:15] + summaries[16:])
    assert monitor.queries.day(subject, day).energy == pytest.approx(reference.queries.day(subject, day).energy, rel=1e-12)
    monitor.close()


@pytest.mark.parametrize("payload", [b"", b"{}", b"[1,2,3]", b'{"device":"w1","seq":0,"t_ms":1,"s":1,"fs":5000,'
                                     b'"ahw":[1,2],"peak":[1,2,3]}', b'{"device":"w1","seq":0,"t_ms":1,"s":1,'
                                     b'"fs":5000,"ahw":[1,2,-3],"peak":[1,2,3]}', b'{"device":"w1","seq":"0",'
                                     b'"t_ms":1,"s":1,"fs":5000,"ahw":[1,2,3],"peak":[1,2,3]}', b"x" * 2000])
def test_a_malformed_summary_is_dead_lettered_never_counted(payload):
    monitor = HavMonitor(None, SECRET, config=MonitorConfig(commit_delay_s=0))
    bus = LocalBus().connect()
    monitor.attach(bus)
    bus.publish(summary_topic("demo", "w1"), payload)
    good = encode_summary(DeviceSummary("w2", 0, time.time(), 1.0, 5000.0, (1.0, 1.0, 1.0), (5.0, 5.0, 5.0)))
    bus.publish(summary_topic("demo", "w1"), good)  # w2's summary on w1's topic: mismatched
    monitor.flush()
    assert monitor.queries.malformed_messages()["w1"].count == 2
    assert monitor.queries.devices() == []
    monitor.close()
