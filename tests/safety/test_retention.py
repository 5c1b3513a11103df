"""Raw samples are kept for people, not for exposure: the newest minute of each device, compressed windows around
events, within an age and a size bound; so a simulated day fits a laptop."""

from __future__ import annotations

import numpy as np

from bim2rdt.bus import LocalBus
from bim2rdt.safety import HavMonitor, MonitorConfig

from hav_helpers import T0, feed, plan_batches

DAY_LIMIT_MB = 24.0
"""A 10-minute simulated day of 3 wearables at 5 kHz (54 MB of int16 samples) stays under this on disk (the store
file and its WAL); keeping every raw batch for the retention took 60 MB."""


def _store_mb(folder) -> float:
    return sum(p.stat().st_size for p in folder.glob("hav.sqlite*")) / 1e6


def test_a_ten_minute_simulated_day_stays_under_the_stated_size(tmp_path):
    from bim2rdt.sim.wearables import default_plans, timed_messages

    now = [T0]
    monitor = HavMonitor(tmp_path / "hav", "test-secret", [], MonitorConfig(site="demo"), lambda: now[0])
    bus = LocalBus().connect()
    monitor.attach(bus)
    for when, _, topic, payload, retain in timed_messages(default_plans(3, 10), "demo", 5000.0, T0):
        now[0] = when + 0.05
        bus.publish(topic, payload, qos=1, retain=retain)
    monitor.flush()
    newest = {d: monitor.queries.reads.last_sample_time(d) for d in monitor.queries.devices()}
    live = {d: monitor.queries.reads.raw_window(d, newest[d] - 10.0, newest[d]) for d in newest}
    started = [e for e in monitor.queries.reads.events("hav.activity_started")]
    around = [monitor.queries.reads.raw_window(e.source, e.time - 5.0, e.time + 5.0) for e in started]
    monitor.close()
    assert _store_mb(tmp_path / "hav") < DAY_LIMIT_MB
    assert all(len(batches) == 20 for batches in live.values())  # the dashboard's live view: the last 10 s
    assert len(started) >= 9 and all(len(batches) >= 19 for batches in around)  # 10 s kept around each start


def test_raw_samples_away_from_events_go_and_those_around_events_come_back_exactly(make_monitor, clock):
    items = plan_batches("dev-1", [("idle", 40), ("grinder", 30), ("idle", 120)], a_hv={"grinder": 6.0})
    monitor, sink = make_monitor(raw_recent_s=20.0, raw_event_margin_s=4.0)
    monitor.start_session("dev-1", "ina", "grinder")
    feed(monitor, items, clock)
    started = next(e for e in sink.events if e.kind == "hav.activity_started")
    kept = monitor.store.raw_seqs("dev-1")
    sent = {b.seq: b for b in items}
    back = monitor.queries.reads.raw_window("dev-1", started.time - 4.0, started.time + 4.0)
    assert 0 not in kept and 100 not in kept  # quiet and mid-activity, older than 20 s: gone
    assert len(back) >= 16 and all(np.array_equal(b.xyz, np.float32(sent[b.seq].xyz)) for b in back)
    assert kept[-40:] == list(range(len(items) - 40, len(items)))  # the newest 20 s


def test_the_raw_samples_are_bounded_by_size(make_monitor, clock):
    items = plan_batches("dev-1", [("grinder", 120)], a_hv={"grinder": 6.0})
    monitor, _ = make_monitor(raw_recent_s=3600.0, raw_max_mb=0.5)  # 15 kB a batch: ~33 batches fit
    monitor.start_session("dev-1", "ola", "grinder")
    feed(monitor, items, clock)  # 10 s a chunk: the size is checked every 10 s of the monitor's clock
    with monitor.store.transaction():
        stored = monitor.store.raw_bytes()
    assert stored <= 0.5e6 + 20 * 30_000  # the bound, plus what arrived since the last check
    assert monitor.store.raw_seqs("dev-1")[-1] == len(items) - 1  # the oldest went first


def test_a_fleet_whose_clocks_run_in_step_does_not_sort_out_in_one_commit():
    """Devices switched on together have the same device times; each sorts out on steps of its own phase, so a
    commit sorts out a few of them, not all (decision 0028)."""
    from bim2rdt.safety.retention import SORT_EVERY_S, RawRetention
    from bim2rdt.safety.store import ExposureStore

    devices = [f"w{k}" for k in range(50)]
    store = ExposureStore(None)
    retention = RawRetention(store, recent_s=60.0, event_margin_s=10.0, retention_s=3600.0,
                             max_bytes=1e9)
    sorted_out: list[str] = []
    retention._sort_out = lambda device, next_seq, cut: (sorted_out.append(device),
                                                         retention._handled.__setitem__(device, cut))
    per_commit, last = [], {}
    for step in range(1, 121):  # a minute of batches of 0.5 s, all devices in every commit
        newest = 60.0 + 0.5 * step
        sorted_out.clear()
        with store.transaction():
            retention.prune([(d, step, newest) for d in devices], now=float(step), next_seq_of=lambda d: step)
        per_commit.append(len(sorted_out))
        for device in sorted_out:
            assert newest - last.get(device, newest - SORT_EVERY_S) <= SORT_EVERY_S + 0.5
            last[device] = newest
    assert per_commit[0] == 50  # the first commit sets where each device stands
    assert max(per_commit[1:]) <= 12  # 50 devices over 10 commits of a step: ~5 each, never all 50
    assert all(newest_seen >= 60.0 + 0.5 * 120 - SORT_EVERY_S for newest_seen in last.values())
