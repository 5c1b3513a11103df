"""Exposure is neither lost nor inflated by what devices do to sequence numbers and scales (issue 10, section 3)."""

from __future__ import annotations

import dataclasses
import json
import struct

import numpy as np
import pytest

from bim2rdt.bus import accel_topic, encode_accel
from bim2rdt.bus.payloads import MAGIC
from bim2rdt.safety import ELV

from hav_helpers import DAY, T0, feed, plan_batches

PLAN = [("idle", 2), ("hammer_drill", 32)]  # 34 s, 68 batches of 0.5 s


@pytest.fixture(scope="module")
def items():
    return plan_batches("dev-1", PLAN, a_hv={"hammer_drill": 10.0})


@pytest.fixture
def reference(make_monitor, clock, items):
    monitor, _ = make_monitor("reference")
    subject = monitor.start_session("dev-1", "rae", "hammer_drill")
    feed(monitor, items, clock)
    clock.now = T0
    return monitor.day(subject, DAY)


def _run(make_monitor, clock, batches, chunk: int = 1):
    monitor, sink = make_monitor()
    subject = monitor.start_session("dev-1", "rae", "hammer_drill")
    feed(monitor, batches, clock, chunk=chunk)
    return monitor, sink, monitor.day(subject, DAY)


def test_one_batch_whose_seq_jumps_by_a_million_costs_nothing(make_monitor, clock, items, reference):
    jumped = [dataclasses.replace(b, seq=b.seq + 10**6) if b.seq == 20 else b for b in items]
    monitor, _, day = _run(make_monitor, clock, jumped)
    assert day.seconds == pytest.approx(reference.seconds) and day.energy == pytest.approx(reference.energy, rel=1e-9)
    status = monitor.stream_status("dev-1")
    assert status.get("late", 0) == 0 and status.get("gaps", 0) == 0 and status["renumbered"] == 1


def test_a_device_reboot_that_restarts_seq_from_zero_loses_nothing(make_monitor, clock, items, reference):
    rebooted = items[:28] + [dataclasses.replace(b, seq=b.seq - 28) for b in items[28:]]
    monitor, _, day = _run(make_monitor, clock, rebooted, chunk=4)
    assert day.energy == pytest.approx(reference.energy, rel=1e-9)
    status = monitor.stream_status("dev-1")
    assert status.get("duplicates", 0) == 0 and status["renumbered"] == 1


def test_after_a_reboot_redeliveries_of_the_old_numbering_are_still_duplicates(make_monitor, clock, items,
                                                                              reference):
    rebooted = items[:28] + [dataclasses.replace(b, seq=b.seq - 28) for b in items[28:40]]
    redelivered = rebooted + items[25:28] + [dataclasses.replace(b, seq=b.seq - 28) for b in items[40:]]
    monitor, _, day = _run(make_monitor, clock, redelivered)
    assert day.energy == pytest.approx(reference.energy, rel=1e-9)
    assert monitor.stream_status("dev-1")["duplicates"] == 3


def test_a_reboot_after_a_pause_is_a_gap_and_the_rest_counts(make_monitor, clock, items):
    paused = items[:28] + [dataclasses.replace(b, seq=b.seq - 28, device_time=b.device_time + 20.0) for b in items[28:]]
    monitor, sink, day = _run(make_monitor, clock, paused)
    gaps = [e for e in sink.events if e.kind == "hav.gap"]
    assert [g.data["reason"] for g in gaps] == ["device time jump"] and gaps[0].data["seconds"] == pytest.approx(20.0)
    assert monitor.stream_status("dev-1").get("duplicates", 0) == 0
    assert day.seconds == pytest.approx(32.0, abs=1.0)


def test_a_seq_of_1e20_is_refused_and_later_commits_work(make_monitor, clock, items, reference):
    monitor, _ = make_monitor()
    subject = monitor.start_session("dev-1", "rae", "hammer_drill")
    payload = encode_accel(items[10])
    head_len = struct.unpack("<H", payload[4:6])[0]
    header = json.loads(payload[6:6 + head_len])
    head = json.dumps({**header, "seq": 1e20}).encode()
    poison = MAGIC + struct.pack("<H", len(head)) + head + payload[6 + head_len:]
    for batch in items:
        clock.now = batch.device_time + 0.6
        monitor.ingest_payload(accel_topic("demo", "dev-1"), encode_accel(batch))
        if batch.seq == 10:
            assert monitor.ingest_payload(accel_topic("demo", "dev-1"), poison) == []
    assert monitor.malformed_messages()["dev-1"].count == 1
    assert monitor.day(subject, DAY).energy == pytest.approx(reference.energy, rel=1e-3)  # int16 quantisation


@pytest.mark.parametrize("scale", [1e30, 1.0])
def test_an_int16_batch_with_an_impossible_scale_is_an_artefact_not_exposure(make_monitor, clock, items, reference,
                                                                             scale):
    monitor, sink = make_monitor()
    subject = monitor.start_session("dev-1", "rae", "hammer_drill")
    for batch in items:
        clock.now = batch.device_time + 0.6
        payload = encode_accel(batch)
        if batch.seq == 30:  # the same counts, a wrong scale: m/s^2 per count of 1e30 (or 1 m/s^2 for 16 g)
            head_len = struct.unpack("<H", payload[4:6])[0]
            head = json.dumps({**json.loads(payload[6:6 + head_len]), "scale": scale}).encode()
            payload = MAGIC + struct.pack("<H", len(head)) + head + payload[6 + head_len:]
        monitor.ingest_payload(accel_topic("demo", "dev-1"), payload)
    day = monitor.day(subject, DAY)
    assert np.isfinite(day.energy) and day.a8 < 1.01 * reference.a8 and day.a8 > 0.9 * reference.a8
    assert "hav.elv_reached" not in sink.kinds()
    kinds = {k for e in sink.events if e.kind == "hav.artefact" for k in e.data["kinds"]}
    assert "impossible" in kinds
