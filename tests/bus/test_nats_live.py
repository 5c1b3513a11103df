"""The scaled path live: 60 simulated wearables over MQTT 3.1.1 to nats-server, 3 monitor processes (one
supervisor) on a shared PostgreSQL store; one monitor is SIGKILLed at ~40 % and its supervisor restarts it. Every
worker's A(8) and counted seconds equal a single in-memory monitor's; every batch is applied exactly once."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
import time

import pytest
import sqlalchemy as sa

from bim2rdt.bus.local import LocalBus
from bim2rdt.bus.nats_broker import NATS_SERVER, NatsServer
from bim2rdt.safety import HavMonitor, MonitorConfig
from bim2rdt.sim.wearables import default_plans, publish_plans
from tests.bus.nats_helpers import wearable
from tests.postgres_server import fresh_database

SITE, SECRET, FS, SPEED = "live", "live-site-secret", 2500.0, 8.0
DEVICES, PARTITIONS, MINUTES = 60, 3, 2.0


@pytest.fixture
def store_url(postgres_admin_url):
    """A fresh PostgreSQL database on the session's server (tests/conftest.py)."""
    with fresh_database(postgres_admin_url) as fresh:
        yield fresh


class Output:
    """A process's stdout lines, read on a thread; ``wait_for(pattern)`` returns the first new match."""

    def __init__(self, process: subprocess.Popen):
        self.lines: list[str] = []
        self._seen = 0
        self._new = threading.Condition()
        threading.Thread(target=self._read, args=(process,), daemon=True).start()

    def _read(self, process) -> None:
        for line in process.stdout:
            with self._new:
                self.lines.append(line)
                self._new.notify_all()

    def wait_for(self, pattern: str, timeout_s: float, start: int = 0) -> re.Match:
        deadline = time.monotonic() + timeout_s
        with self._new:
            while True:
                for line in self.lines[start:]:
                    if match := re.search(pattern, line):
                        return match
                if not self._new.wait(max(deadline - time.monotonic(), 0.0)) and time.monotonic() > deadline:
                    pytest.fail(f"no {pattern!r} within {timeout_s} s: {''.join(self.lines)[-600:]!r}")


def reference_days(plans, t0: float) -> dict:
    monitor = HavMonitor(None, SECRET, config=MonitorConfig(site=SITE))
    bus = LocalBus().connect()
    monitor.attach(bus)
    publish_plans(lambda device: bus, plans, SITE, FS, t0=t0)
    monitor.flush()
    return {(d, day): (monitor.queries.day(monitor.queries.session(d).subject, day).a8, monitor.queries.day(monitor.queries.session(d).subject,
                                                                                  day).seconds)
            for d in [p.device for p in plans] for day in monitor.queries.days_of(monitor.queries.session(d).subject)}


def applied_per_device(url: str) -> dict[str, int]:
    engine = sa.create_engine(url)
    try:
        with engine.connect() as conn:
            return dict(conn.exec_driver_sql("SELECT device, count(*) FROM applied GROUP BY device").fetchall())
    except sa.exc.ProgrammingError:  # no table yet
        return {}
    finally:
        engine.dispose()


def test_a_killed_monitor_process_loses_and_doubles_nothing_on_a_shared_postgresql_store(store_url, tmp_path):
    if not os.path.exists(NATS_SERVER):
        pytest.fail("Debian's nats-server is required (.ci/run installs it)")
    plans = default_plans(DEVICES, MINUTES)
    devices = {p.device: f"{p.device}-pw" for p in plans}
    with NatsServer(SITE, devices, {"monitor": "monitor-pw"}, partitions=PARTITIONS,
                    folder=tmp_path / "nats") as server:
        env = {**os.environ, "BIM2RDT_DATA_DIR": str(tmp_path / "data"), "BIM2RDT_MQTT__SITE": SITE,
               "BIM2RDT_MQTT__USERNAME": "monitor", "BIM2RDT_MQTT__PASSWORD": "monitor-pw",
               "BIM2RDT_HAV__SITE_SECRET": SECRET, "BIM2RDT_HAV__STORE_URL": store_url, "PYTHONUNBUFFERED": "1",
               "COLUMNS": "200"}
        supervisor = subprocess.Popen([sys.executable, "-m", "bim2rdt", "hav", "listen", "--nats", server.url,
                                       "--partitions", str(PARTITIONS)], env=env, stdout=subprocess.PIPE,
                                      stderr=subprocess.STDOUT, text=True)
        out, started = Output(supervisor), time.monotonic()
        try:
            pids = {}
            for k in range(PARTITIONS):
                match = out.wait_for(rf"partition {k}/{PARTITIONS} of site .* \(pid (\d+)\)", 60)
                pids[k] = int(match.group(1))
            print(f"\nmonitors up after {time.monotonic() - started:.1f} s")
            buses = {device: wearable(server, device, password) for device, password in devices.items()}
            t0, total = time.time(), max(sum(s for _, s in p.pieces) for p in plans)
            killed = {}

            def kill_at_40_percent(elapsed: float) -> None:
                if not killed and elapsed >= 0.4 * total:
                    seen = len(out.lines)
                    os.kill(pids[1], signal.SIGKILL)
                    killed.update(at=time.monotonic())
                    watcher.start()
                    killed["seen"] = seen

            def see_it_back() -> None:  # the supervisor's restart: the partition's new monitor says it serves
                while "seen" not in killed:
                    time.sleep(0.01)
                back = out.wait_for(rf"partition 1/{PARTITIONS} of site .* \(pid (\d+)\)", 30, start=killed["seen"])
                killed.update(back_at=time.monotonic(), pid=int(back.group(1)))

            watcher = threading.Thread(target=see_it_back, daemon=True)

            publish_plans(buses.__getitem__, plans, SITE, FS, speed=SPEED, t0=t0, tick=kill_at_40_percent)
            for bus in buses.values():
                assert bus.drain(60.0)
                bus.close()
            assert killed, "the kill never happened"
            watcher.join(35)
            assert killed.get("pid") not in (None, pids[1])
            print(f"published after {time.monotonic() - started:.1f} s")
            want_batches = _batches_per_device(plans)
            deadline = time.monotonic() + 60
            while sum(applied_per_device(store_url).values()) < sum(want_batches.values()) and \
                    time.monotonic() < deadline:
                time.sleep(0.5)
            print(f"all applied after {time.monotonic() - started:.1f} s")
        finally:
            supervisor.send_signal(signal.SIGTERM)
            supervisor.wait(timeout=60)
    assert supervisor.returncode == 0, "".join(out.lines)[-2000:]
    applied = applied_per_device(store_url)
    assert applied == want_batches  # each batch applied exactly once: none missing, none twice (a key is unique)
    print(f"\nlive: {sum(applied.values())} batches from {len(applied)} devices applied once each; partition 1 "
          f"served again {killed['back_at'] - killed['at']:.1f} s after its SIGKILL")
    assert killed["back_at"] - killed["at"] <= 10.0  # the partition is served again within 10 s
    monitor = HavMonitor(tmp_path / "check", SECRET, config=MonitorConfig(site=SITE, store_url=store_url))
    got = {(d, day): (monitor.queries.day(monitor.queries.session(d).subject, day).a8,
                      monitor.queries.day(monitor.queries.session(d).subject, day).seconds)
           for d in devices for day in monitor.queries.days_of(monitor.queries.session(d).subject)}
    counted = {d: monitor.queries.stream_status(d)["batches"] for d in devices}
    monitor.close()
    want = reference_days(plans, t0)
    assert got.keys() == want.keys() and len(want) == DEVICES
    for key, (a8, seconds) in want.items():
        assert abs(got[key][0] - a8) <= 1e-9 and abs(got[key][1] - seconds) <= 1e-9, (key, got[key], want[key])
    assert sum(counted.values()) >= sum(want_batches.values())  # redelivered ones are counted as received, too


def _batches_per_device(plans) -> dict[str, int]:
    from bim2rdt.sim.wearables import timed_messages

    counts: dict[str, int] = {}
    for _, device, topic, _, _ in timed_messages(plans, SITE, FS, 0.0):
        if topic.endswith("/accel"):
            counts[device] = counts.get(device, 0) + 1
    return counts
