"""The dashboard's one clock: the demo's simulated wearables, the twin's records and the page's header all run on
the demo's simulated site day (``demo_clock``); a real server's clock is the wall clock."""

from __future__ import annotations

import time

import httpx

from server_helpers import SITE_SECRET, T_TWIN, auth, config_with_tokens


def test_a_server_over_real_sources_tells_the_page_the_wall_clock(client):
    answer = client.get("/api/clock", headers=auth(client.tokens["viewer"])).json()
    assert abs(answer["now"] - time.time()) < 5.0
    assert answer["speed"] == 1.0 and answer["simulated"] is False


def test_the_demos_wearables_and_header_run_on_the_twins_simulated_day(tmp_path, twin):
    from bim2rdt.bus import LocalBus
    from bim2rdt.demo.serve import LiveWearables, demo_clock
    from bim2rdt.safety import HavMonitor, MonitorConfig
    from bim2rdt.server import create_app
    from bim2rdt.server.runner import ServerThread
    from bim2rdt.sim.wearables import WorkerPlan

    speed = 200.0
    clock = demo_clock(twin, speed)
    last_record = max(event.time for event in twin.events())
    assert last_record <= clock.origin_s < last_record + 1.0  # the day goes on from the twin's last record
    monitor = HavMonitor(tmp_path / "hav", SITE_SECRET, config=MonitorConfig(site="test"))
    try:
        bus = LocalBus().connect()
        monitor.attach(bus)
        plan = WorkerPlan("w1", "worker-001", None, (("idle", 1.0), ("grinder", 4.0), ("idle", 1.0)))
        wearables = LiveWearables(monitor, bus, [plan], "test", speed=speed, t0=clock.origin_s).start()
        wearables._threads[0].join(30)  # the publisher: done once the 6 s plan is sent
        wearables.stop()
        monitor.flush()
        times = [event.time for event in monitor.queries.reads.events()]
        assert times and all(clock.origin_s <= t <= clock.origin_s + 7.0 for t in times), times

        config, tokens = config_with_tokens(tmp_path)
        app = create_app(twin, monitor, config=config, clock=clock)
        with ServerThread(app) as server:
            before = clock.now()
            answer = httpx.get(f"{server.url}/api/clock", headers=auth(tokens["viewer"]), timeout=30).json()
            after = clock.now()
    finally:
        monitor.close()
    assert before <= answer["now"] <= after and answer["speed"] == speed and answer["simulated"] is True
    assert abs(answer["now"] - T_TWIN) < 3600.0  # the header shows the twin's day, not the wall clock
