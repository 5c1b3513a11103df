"""Partition monitors sharing one store: each restores only the devices it owns; a reader (serve --nats) refreshed
from the store shows every partition's workers, and their figures only grow between refreshes."""

from __future__ import annotations

import time

from bim2rdt.safety import HavMonitor, MonitorConfig
from bim2rdt.server.safety_view import SafetyView
from bim2rdt.sim.vibration import ToolSignal, batches

FS, SECRET = 2500.0, "partition-secret"


def shift(device: str, t0: float, seconds: float) -> list:
    signal = ToolSignal("hammer_drill", seconds, FS, 9.0, seed=4).samples()
    return list(batches(device, signal, FS, t0))


def test_partitions_on_one_store_restore_their_own_devices_and_a_reader_sees_every_worker(tmp_path):
    config = MonitorConfig(store_url=f"sqlite:///{tmp_path / 'shared.sqlite'}")
    t0 = time.time() - 60
    one = HavMonitor(tmp_path / "p0", SECRET, config=config, owns=lambda device: device == "w1")
    two = HavMonitor(tmp_path / "p1", SECRET, config=config, owns=lambda device: device == "w2")
    ann, bob = one.start_session("w1", "ann", "hammer_drill"), two.start_session("w2", "bob", "hammer_drill")
    w1, w2 = shift("w1", t0, 20.0), shift("w2", t0, 20.0)
    one.ingest_many(w1[:20])
    two.ingest_many(w2)
    reader = HavMonitor(tmp_path / "serve", SECRET, config=config)
    view = SafetyView(reader.queries)
    assert {w["subject"] for w in view.workers()} == {ann, bob}
    day = reader.queries.days_of(ann)[0]
    before = reader.queries.day(ann, day).energy
    one.ingest_many(w1[20:])
    assert reader.queries.day(ann, day).energy == before  # a reader holds what it last read ...
    reader.refresh()
    assert reader.queries.day(ann, day).energy == one.queries.day(ann, day).energy > before  # ... and grows with the store
    assert reader.queries.day(bob, day).energy == two.queries.day(bob, day).energy
    one.close()
    again = HavMonitor(tmp_path / "p0", SECRET, config=config, owns=lambda device: device == "w1")
    assert again.queries.devices() == ["w1"]  # a restarted partition takes back only its own streams
    assert again.queries.day(ann, day).energy == reader.queries.day(ann, day).energy
    for monitor in (again, two, reader):
        monitor.close()


def test_serve_nats_without_a_shared_store_is_refused_in_one_line(tmp_path):
    import os
    import subprocess
    import sys

    result = subprocess.run([sys.executable, "-m", "bim2rdt", "serve", "--nats", "nats://127.0.0.1:1", "--out",
                             str(tmp_path / "demo")], capture_output=True, text=True, timeout=120,
                            env={k: v for k, v in os.environ.items() if k != "BIM2RDT_HAV__STORE_URL"})
    assert result.returncode == 1 and "BIM2RDT_HAV__STORE_URL" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
