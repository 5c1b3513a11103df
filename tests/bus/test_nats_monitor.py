"""Monitors on the NATS path: one per partition, each a durable pull consumer acknowledging after its commit; the
exposure they count equals one in-memory monitor's on the same messages."""

from __future__ import annotations

import time

import pytest

from bim2rdt.bus.local import LocalBus
from bim2rdt.bus.nats_bus import NatsBus
from bim2rdt.bus.partitions import partition_of
from bim2rdt.safety import HavMonitor, MonitorConfig
from bim2rdt.sim.wearables import default_plans, publish_plans
from tests.bus.conftest import SITE
from tests.bus.nats_helpers import wearable

FS = 2500.0
SECRET = "nats-test-secret"
CONFIG = MonitorConfig(site=SITE, commit_delay_s=0.05)


def reference_days(plans, t0: float) -> dict:
    """{(device, day): (A(8), seconds)} of one in-memory monitor fed the same messages in process."""
    monitor = HavMonitor(None, SECRET, config=CONFIG)
    bus = LocalBus().connect()
    monitor.attach(bus)
    publish_plans(lambda device: bus, plans, SITE, FS, t0=t0)
    monitor.flush()
    return days_of(monitor, [p.device for p in plans])


def days_of(monitor, devices) -> dict:
    out = {}
    for device in devices:
        session = monitor.queries.session(device)
        if session is None:
            continue
        for day in monitor.queries.days_of(session.subject):
            state = monitor.queries.day(session.subject, day)
            out[(device, day)] = (state.a8, state.seconds)
    return out


def assert_same_days(got: dict, want: dict) -> None:
    """Every worker-day's A(8) and counted seconds within 1e-9 of the reference's."""
    assert got.keys() == want.keys() and want
    for key, (a8, seconds) in want.items():
        assert abs(got[key][0] - a8) <= 1e-9 and abs(got[key][1] - seconds) <= 1e-9, (key, got[key], want[key])


def partition_monitor(server, k: int, folder, **bus_options) -> tuple[HavMonitor, NatsBus]:
    monitor = HavMonitor(folder / f"p{k}", SECRET, config=CONFIG)
    bus = NatsBus(server.url, "monitor", server.layout.monitors["monitor"], SITE, partition=k,
                  partitions=server.layout.partitions, **bus_options)
    monitor.attach(bus)
    bus.accepting = lambda: monitor.failure is None  # as hav listen --nats
    return monitor, bus.connect()


def publish_over_mqtt(server, plans, t0: float) -> int:
    buses = {plan.device: wearable(server, plan.device) for plan in plans}
    try:
        sent = publish_plans(buses.__getitem__, plans, SITE, FS, t0=t0)
        for bus in buses.values():
            assert bus.drain(60.0)
        return sent
    finally:
        for bus in buses.values():
            bus.close()


def wait_delivered(buses, count: int, timeout_s: float = 60.0) -> None:
    deadline = time.monotonic() + timeout_s
    while sum(bus.delivered for bus in buses) < count and time.monotonic() < deadline:
        time.sleep(0.1)
    assert sum(bus.delivered for bus in buses) >= count, [
        (bus.delivered, bus.handler_errors, bus.alive, bus._fetched.qsize(),
         bus._fetcher.exception() if bus._fetcher is not None and bus._fetcher.done() else None) for bus in buses]


def test_three_partition_monitors_count_what_one_in_memory_monitor_counts(nats_server, tmp_path):
    plans = default_plans(6, 1.0)
    t0 = time.time()
    parts = [partition_monitor(nats_server, k, tmp_path) for k in range(3)]
    sent = publish_over_mqtt(nats_server, plans, t0)
    wait_delivered([bus for _, bus in parts], sent)
    got = {}
    for k, (monitor, bus) in enumerate(parts):
        monitor.flush()
        bus.close()
        assert {d for d in monitor.queries.devices()} == {p.device for p in plans if partition_of(SITE, p.device, 3) == k}
        got.update(days_of(monitor, monitor.queries.devices()))
        monitor.close()
    want = reference_days(plans, t0)
    assert len(want) == 6 and sum(seconds for _, seconds in want.values()) > 60
    assert_same_days(got, want)


def test_a_message_whose_commit_failed_is_redelivered_and_applied_once(nats_server, tmp_path):
    plans = default_plans(1, 1.0)
    device, t0 = plans[0].device, time.time()
    k = partition_of(SITE, device, 3)
    monitor, bus = partition_monitor(nats_server, k, tmp_path, ack_wait_s=2.0)
    real_commit, failures = monitor._journal.commit, []

    def fail_once(*args, **kwargs):
        if not failures and args[1]:  # the first commit that holds batches
            failures.append(len(args[1]))
            raise OSError("disk full (injected)")
        return real_commit(*args, **kwargs)

    monitor._journal.commit = fail_once
    sent = publish_over_mqtt(nats_server, plans, t0)
    time.sleep(1.0)
    assert failures and monitor.failure and "disk full" in monitor.failure
    bus.close()  # hav listen exits on monitor.failure; the supervisor starts a new monitor on the same store
    monitor.store.close()

    monitor, bus = partition_monitor(nats_server, k, tmp_path)
    wait_delivered([bus], failures[0])
    deadline = time.monotonic() + 30
    while monitor.queries.stream_status(device) is None or monitor.queries.stream_status(device)["next_seq"] is None or \
            monitor.queries.stream_status(device)["batches"] < sent - 4 and time.monotonic() < deadline:
        time.sleep(0.1)
    time.sleep(0.5)
    monitor.flush()
    bus.close()
    assert bus.delivered >= failures[0] + 1  # the uncommitted group (and the status after it) came again ...
    assert_same_days(days_of(monitor, [device]), reference_days(plans, t0))  # ... and counted once
    monitor.close()


def test_poison_over_nats_is_refused_and_counted_as_over_mqtt_and_leaves_the_good_stream_exact(nats_server, tmp_path):
    """The same hostile payloads as tests/bus/test_fuzz.py's, from a device through nats-server's MQTT listener:
    each is dead-lettered and acknowledged, and the good batches interleaved with them give their own A(8)."""
    import json

    from hypothesis import given, settings
    from hypothesis import strategies as st

    from bim2rdt.bus.topics import accel_topic, status_topic
    from bim2rdt.bus.payloads import encode_accel
    from test_fuzz import FUZZ, _as, _good
    from poison import BAD_STATUS, poison_accel

    device, t0 = "w4", time.time()
    good = _good(device, t0, seconds=6.0)
    accel, status = accel_topic(SITE, device), status_topic(SITE, device)
    k = partition_of(SITE, device, 3)
    monitor, bus = partition_monitor(nats_server, k, tmp_path)
    w4 = wearable(nats_server, device)
    w4.publish(status, json.dumps({"online": True, "worker": "fay", "tool": "hammer_drill"}).encode(), qos=1)
    sent = {"poison": 0, "good": 0, "all": 1}

    @settings(FUZZ, max_examples=12)
    @given(poison=st.lists(st.one_of(poison_accel.map(lambda p: (accel, _as(p, device))),
                                     BAD_STATUS.map(lambda p: (status, p))), min_size=20, max_size=40))
    def publish_round(poison):
        for topic, payload in poison:
            w4.publish(topic, payload, qos=1)
        sent["poison"] += len(poison)
        if sent["good"] < len(good):
            w4.publish(accel, encode_accel(good[sent["good"]]), qos=1)
            sent["good"] += 1

    publish_round()
    for batch in good[sent["good"]:]:
        w4.publish(accel, encode_accel(batch), qos=1)
    assert w4.drain(30.0)
    w4.close()
    wait_delivered([bus], sent["poison"] + len(good) + 1)
    monitor.flush()
    bus.close()
    reference = HavMonitor(None, SECRET, config=CONFIG, clock=lambda: t0)
    subject = reference.start_session(device, "fay", "hammer_drill")
    reference.ingest_many(good, now=t0 + 100)
    day = reference.queries.days_of(subject)[0]
    assert sent["poison"] >= 200
    assert monitor.queries.malformed_messages()[device].count == sent["poison"]
    assert monitor.queries.day(subject, day).energy == pytest.approx(reference.queries.day(subject, day).energy, rel=1e-9)
    reference.close()
    monitor.close()


def test_a_worker_whose_two_devices_fall_in_two_partitions_reads_as_one_process_counts_the_pair(nats_server,
                                                                                                  tmp_path):
    """Two partition monitors on one shared store each count one of the worker's devices; the read API
    (/api/workers' SafetyView on a reader of that store) gives the worker the A(8) and seconds one in-memory
    monitor gives the pair."""
    from bim2rdt.safety.persistence import Share
    from bim2rdt.server.safety_view import SafetyView
    from bim2rdt.sim.wearables import WorkerPlan

    left = "w1"
    right = next(d for d in ("w2", "w3", "w4", "w5", "w6") if partition_of(SITE, d, 3) != partition_of(SITE, left, 3))
    plans = [WorkerPlan(left, "ann", None, (("idle", 2.0), ("hammer_drill", 20.0), ("idle", 3.0))),
             WorkerPlan(right, "ann", None, (("idle", 6.0), ("grinder", 25.0), ("idle", 3.0)), 0.8)]
    t0 = time.time()
    reference = HavMonitor(None, SECRET, config=CONFIG)
    local = LocalBus().connect()
    reference.attach(local)
    publish_plans(lambda device: local, plans, SITE, FS, t0=t0)
    reference.flush()
    subject = reference.queries.session(left).subject
    want = reference.queries.day(subject)
    assert reference.queries.session(right).subject == subject and want.seconds > 40  # both devices' time counts

    shared = CONFIG.model_copy(update={"store_url": f"sqlite:///{tmp_path / 'shared.sqlite'}"})
    parts = []
    for device in (left, right):
        k = partition_of(SITE, device, 3)
        monitor = HavMonitor(tmp_path / f"p{k}", SECRET, config=shared, owns=Share(SITE, k, 3))
        bus = NatsBus(nats_server.url, "monitor", nats_server.layout.monitors["monitor"], SITE, partition=k,
                      partitions=3)
        monitor.attach(bus)
        bus.on_fetched = monitor.flush
        parts.append((monitor, bus.connect()))
    sent = publish_over_mqtt(nats_server, plans, t0)
    wait_delivered([bus for _, bus in parts], sent)
    for monitor, bus in parts:
        monitor.flush()
        bus.close()
    reader = HavMonitor(tmp_path / "serve", SECRET, config=shared)
    worker = next(w for w in SafetyView(reader.queries).workers() if w["subject"] == subject)
    assert abs(worker["a8"] - want.a8) <= 1e-9 and abs(worker["exposure_s"] - want.seconds) <= 1e-9
    assert {d["device"] for d in worker["devices"]} == {left, right}
    for monitor in (*[m for m, _ in parts], reader, reference):
        monitor.close()
