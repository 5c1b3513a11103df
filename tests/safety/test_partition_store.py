"""Partition monitors sharing one store: each restores only the devices it owns; a reader (serve --nats) refreshed
from the store shows every partition's workers, and their figures only grow between refreshes."""

from __future__ import annotations

import pytest

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


def _two_partitions(site: str, partitions: int) -> tuple[str, str]:
    """Two device ids of ``site`` that hash to different partitions."""
    from bim2rdt.bus.partitions import partition_of

    first = "d1"
    other = next(f"d{i}" for i in range(2, 100) if partition_of(site, f"d{i}", partitions) !=
                 partition_of(site, first, partitions))
    return first, other


def test_a_worker_wearing_two_devices_in_two_partitions_reads_the_sum_of_both_as_one_process_counts_it(tmp_path):
    from bim2rdt.bus.partitions import partition_of
    from bim2rdt.safety.persistence import OTHERS_REFRESH_S, Share

    site, n = "demo", 3
    config = MonitorConfig(site=site, store_url=f"sqlite:///{tmp_path / 'shared.sqlite'}")
    left, right = _two_partitions(site, n)
    t0 = time.time() - 120
    shifts = {left: shift(left, t0, 30.0), right: shift(right, t0 + 7.0, 40.0)}

    reference = HavMonitor(None, SECRET, config=MonitorConfig(site=site))
    ann = reference.start_session(left, "ann", "hammer_drill")
    reference.start_session(right, "ann", "grinder")
    reference.ingest_many(shifts[left] + shifts[right])
    day = reference.queries.days_of(ann)[0]
    want = reference.queries.day(ann, day)
    assert want.seconds > 60  # both devices' trigger time counts

    now = [time.time()]
    monitors = {d: HavMonitor(tmp_path / d, SECRET, config=config, owns=Share(site, partition_of(site, d, n), n),
                              clock=lambda: now[0]) for d in (left, right)}
    for device, monitor in monitors.items():
        monitor.start_session(device, "ann", "hammer_drill" if device == left else "grinder")
    for half in (slice(0, 25), slice(25, None)):  # the two processes commit in turn, each its own share
        for device, monitor in monitors.items():
            monitor.ingest_many(shifts[device][half])
    monitors[left].close()  # a partition restarts: its share comes back from the store, not the whole day
    monitors[left] = HavMonitor(tmp_path / left, SECRET, config=config,
                                owns=Share(site, partition_of(site, left, n), n), clock=lambda: now[0])
    monitors[right].ingest_many(shifts[right][-1:])  # a redelivered batch: a duplicate, counted once

    reader = HavMonitor(tmp_path / "serve", SECRET, config=config)
    worker = next(w for w in SafetyView(reader.queries).workers() if w["subject"] == ann)
    assert abs(worker["a8"] - want.a8) <= 1e-9 and abs(worker["exposure_s"] - want.seconds) <= 1e-9
    assert {d["device"] for d in worker["devices"]} == {left, right}
    now[0] += OTHERS_REFRESH_S
    for device, monitor in monitors.items():  # each writer's memory holds the whole day too (its EAV/ELV events
        monitor.ingest_many(shifts[device][-1:])  # see it), the other share re-read at its next commit
        assert abs(monitor.queries.day(ann, day).a8 - want.a8) <= 1e-9
    for monitor in (*monitors.values(), reader, reference):
        monitor.close()


def test_partition_identities_reveal_a_worker_from_whichever_partition_remembered_them(tmp_path):
    from bim2rdt.safety import AccessDenied, IdentityMap, PartitionIdentities

    hav = tmp_path / "hav"
    for k, (alias, worker) in enumerate([("p-ann", "ann"), ("p-bob", "bob")]):
        remembered = IdentityMap(hav / f"partition-{k}-of-2" / "private" / "identity.sqlite", role="monitor")
        remembered.remember(alias, worker)
        remembered.close()
    identities = PartitionIdentities(hav, role="safety")
    assert (identities.real_name("p-ann"), identities.real_name("p-bob"), identities.real_name("p-eve")) == \
        ("ann", "bob", None)
    later = IdentityMap(hav / "partition-1-of-2" / "private" / "identity.sqlite", role="monitor")
    later.remember("p-eve", "eve")  # remembered after the reader started
    later.close()
    assert identities.real_name("p-eve") == "eve"
    identities.close()
    with pytest.raises(AccessDenied):
        PartitionIdentities(hav, role="viewer").real_name("p-ann")


def test_serve_nats_with_an_unreachable_server_is_one_line_and_creates_no_demo_folder(tmp_path, site_ifc):
    import os
    import subprocess
    import sys

    from bim2rdt.twin import DigitalTwin

    with DigitalTwin.open(f"sqlite:///{tmp_path / 'twin.db'}", site_ifc):
        pass
    env = {**os.environ, "BIM2RDT_HAV__STORE_URL": f"sqlite:///{tmp_path / 'hav.sqlite'}",
           "BIM2RDT_DATA_DIR": str(tmp_path / "var"), "BIM2RDT_MQTT__PASSWORD": "monitor-pw"}
    result = subprocess.run([sys.executable, "-m", "bim2rdt", "serve", "--nats", "nats://127.0.0.1:1", "--twin",
                             f"sqlite:///{tmp_path / 'twin.db'}", "--ifc", str(site_ifc), "--port", "0",
                             "--duration", "1"], capture_output=True, text=True, timeout=120, env=env,
                            cwd=tmp_path)
    assert result.returncode == 1 and "dashboard:" not in result.stdout, result.stdout + result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "cannot use NATS at nats://127.0.0.1:1" in lines[0], result.stderr
    assert not (tmp_path / "out").exists()
