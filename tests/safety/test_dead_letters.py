"""Messages the monitor refuses are dead-lettered: counted per device, persisted, never raised, never exposure."""

from __future__ import annotations

import logging
import struct

import pytest

from bim2rdt.bus import LocalBus, accel_topic, encode_accel, status_topic
from bim2rdt.bus.payloads import MAGIC

from hav_helpers import DAY, plan_batches

POISON = [b"", b"garbage", MAGIC + struct.pack("<H", 18) + b'{"full_scale": {}}',
          MAGIC + struct.pack("<H", 30000) + b"[" * 30000]


def test_poison_on_a_device_topic_is_counted_under_that_device_and_never_raises(make_monitor, clock):
    monitor, _ = make_monitor()
    for payload in POISON:
        assert monitor.ingest_payload(accel_topic("demo", "w7"), payload) == []
    refused = monitor.queries.malformed_messages()
    assert set(refused) == {"w7"} and refused["w7"].count == len(POISON)
    assert "HAV1" in refused["w7"].last_reason or "header" in refused["w7"].last_reason
    assert refused["w7"].last_received == clock.now and monitor.queries.stats["malformed"] == len(POISON)
    assert monitor.queries.devices() == []  # no stream, no exposure


def test_refused_counts_survive_a_restart(make_monitor, clock):
    monitor, _ = make_monitor()
    monitor.ingest_payload(accel_topic("demo", "w7"), b"garbage")
    monitor.on_status(status_topic("demo", "w8"), b'{"online": "yes"}')
    monitor.close()
    again, _ = make_monitor()
    assert {d: m.count for d, m in again.queries.malformed_messages().items()} == {"w7": 1, "w8": 1}


def test_a_malformed_status_is_dead_lettered_and_starts_no_session(make_monitor, clock):
    monitor, _ = make_monitor()
    for payload in (b'{"online": true, "worker": {"x": 1}}', b'{"online": 1}', b"[]", b"{" * 5000):
        assert monitor.on_status(status_topic("demo", "w2"), payload) == []
    assert monitor.queries.session("w2") is None and monitor.queries.malformed_messages()["w2"].count == 4


def test_refused_messages_are_logged_with_their_device_then_thinned(make_monitor, caplog):
    monitor, _ = make_monitor()
    with caplog.at_level(logging.WARNING, logger="bim2rdt.safety"):
        for _ in range(50):
            monitor.ingest_payload(accel_topic("demo", "w9"), b"garbage")
    lines = [r.getMessage() for r in caplog.records if "w9" in r.getMessage()]
    assert 1 <= len(lines) <= 6 and "device w9" in lines[0]


def test_an_engine_failure_dead_letters_its_group_and_memory_matches_the_store(make_monitor, clock, monkeypatch):
    items = plan_batches("dev-1", [("idle", 2), ("grinder", 10)])
    monitor, _ = make_monitor(commit_batches=4, commit_delay_s=10.0)
    subject = monitor.start_session("dev-1", "ida", "grinder")
    bus = LocalBus().connect()
    monitor.attach(bus)
    for batch in items[:8]:
        bus.publish(accel_topic("demo", "dev-1"), encode_accel(batch))
    committed = monitor.queries.day(subject, DAY).energy
    engine = type(monitor._engine)
    original = engine.push
    monkeypatch.setattr(engine, "push", lambda self, *a, **k: (_ for _ in ()).throw(ZeroDivisionError("bug")))
    for batch in items[8:12]:
        bus.publish(accel_topic("demo", "dev-1"), encode_accel(batch))  # a group the engine fails on
    monkeypatch.setattr(engine, "push", original)
    assert monitor.queries.malformed_messages()["dev-1"].count == 4
    assert "internal error: ZeroDivisionError" in monitor.queries.malformed_messages()["dev-1"].last_reason
    assert monitor.queries.stream_status("dev-1")["next_seq"] == 8 and monitor.queries.day(subject, DAY).energy == committed
    for batch in items[12:]:
        bus.publish(accel_topic("demo", "dev-1"), encode_accel(batch))  # it goes on: a gap, then exposure again
    monitor.flush()
    assert monitor.queries.day(subject, DAY).energy > committed and monitor.queries.stream_status("dev-1")["gaps"] == 1


def test_a_valid_header_declaring_a_minute_at_100_khz_is_refused_by_its_size_before_decoding(make_monitor, monkeypatch):
    import numpy as np

    from bim2rdt.bus.payloads import AccelBatch
    from bim2rdt.safety import subscriber

    monitor, _ = make_monitor()
    flood = encode_accel(AccelBatch("w7", 0, 1.7e9, 100_000.0, np.zeros((600_000, 3), np.float32)))  # 7 MB
    monkeypatch.setattr(subscriber, "decode_accel", lambda payload: pytest.fail("decoded an oversized message"))
    assert monitor.ingest_payload(accel_topic("demo", "w7"), flood) == []
    refused = monitor.queries.malformed_messages()["w7"]
    assert refused.count == 1 and f"over the {monitor.config.max_message_bytes}-byte bound" in refused.last_reason


def test_the_projects_wearable_batches_are_well_inside_the_message_bound():
    import numpy as np

    from bim2rdt.bus.payloads import AccelBatch
    from bim2rdt.safety.config import MAX_MESSAGE_BYTES

    half_second_at_5khz = encode_accel(AccelBatch("w1", 0, 1.7e9, 5000.0, np.zeros((2500, 3), np.float32)))
    assert 2 * len(half_second_at_5khz) <= MAX_MESSAGE_BYTES
