"""Exposure is neither lost nor inflated by what devices do to sequence numbers and scales (issue 10, section 3)."""

from __future__ import annotations

import dataclasses
import json
import struct

import numpy as np
import pytest

from bim2rdt.bus import accel_topic, encode_accel, status_topic
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
    return monitor.queries.day(subject, DAY)


def _run(make_monitor, clock, batches, chunk: int = 1):
    monitor, sink = make_monitor()
    subject = monitor.start_session("dev-1", "rae", "hammer_drill")
    feed(monitor, batches, clock, chunk=chunk)
    return monitor, sink, monitor.queries.day(subject, DAY)


def test_one_batch_whose_seq_jumps_by_a_million_costs_nothing(make_monitor, clock, items, reference):
    jumped = [dataclasses.replace(b, seq=b.seq + 10**6) if b.seq == 20 else b for b in items]
    monitor, _, day = _run(make_monitor, clock, jumped)
    assert day.seconds == pytest.approx(reference.seconds) and day.energy == pytest.approx(reference.energy, rel=1e-9)
    status = monitor.queries.stream_status("dev-1")
    assert status.get("late", 0) == 0 and status.get("gaps", 0) == 0 and status["renumbered"] == 1


def test_a_device_reboot_that_restarts_seq_from_zero_loses_nothing(make_monitor, clock, items, reference):
    rebooted = items[:28] + [dataclasses.replace(b, seq=b.seq - 28) for b in items[28:]]
    monitor, _, day = _run(make_monitor, clock, rebooted, chunk=4)
    assert day.energy == pytest.approx(reference.energy, rel=1e-9)
    status = monitor.queries.stream_status("dev-1")
    assert status.get("duplicates", 0) == 0 and status["renumbered"] == 1


def test_after_a_reboot_redeliveries_of_the_old_numbering_are_still_duplicates(make_monitor, clock, items,
                                                                              reference):
    rebooted = items[:28] + [dataclasses.replace(b, seq=b.seq - 28) for b in items[28:40]]
    redelivered = rebooted + items[25:28] + [dataclasses.replace(b, seq=b.seq - 28) for b in items[40:]]
    monitor, _, day = _run(make_monitor, clock, redelivered)
    assert day.energy == pytest.approx(reference.energy, rel=1e-9)
    assert monitor.queries.stream_status("dev-1")["duplicates"] == 3


def test_a_reboot_after_a_pause_is_a_gap_and_the_rest_counts(make_monitor, clock, items):
    paused = items[:28] + [dataclasses.replace(b, seq=b.seq - 28, device_time=b.device_time + 20.0) for b in items[28:]]
    monitor, sink, day = _run(make_monitor, clock, paused)
    gaps = [e for e in sink.events if e.kind == "hav.gap"]
    assert [g.data["reason"] for g in gaps] == ["device time jump"] and gaps[0].data["seconds"] == pytest.approx(20.0)
    assert monitor.queries.stream_status("dev-1").get("duplicates", 0) == 0
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
    assert monitor.queries.malformed_messages()["dev-1"].count == 1
    assert monitor.queries.day(subject, DAY).energy == pytest.approx(reference.energy, rel=1e-3)  # int16 quantisation


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
    day = monitor.queries.day(subject, DAY)
    assert np.isfinite(day.energy) and day.a8 < 1.01 * reference.a8 and day.a8 > 0.9 * reference.a8
    assert "hav.elv_reached" not in sink.kinds()
    kinds = {k for e in sink.events if e.kind == "hav.artefact" for k in e.data["kinds"]}
    assert "impossible" in kinds


# --- a restart that resets the device clock (a clock counting from boot) -------------------------------------------
REBOOT_AT = 28  # the device restarts after 14 s: its seq and its clock start over


def _clock_reset(items, boot_offset: float = 0.123):
    """The batches after REBOOT_AT renumbered from 0, their device time back to ``boot_offset`` after T0."""
    t_reboot = items[REBOOT_AT].device_time
    return [dataclasses.replace(b, seq=b.seq - REBOOT_AT, device_time=b.device_time - t_reboot + T0 + boot_offset)
            for b in items[REBOOT_AT:]]


@pytest.fixture
def halves(make_monitor, clock, items):
    """Energy and seconds of the two halves counted on two fresh monitors, summed: what the reboot must give."""
    energy = seconds = 0.0
    for name, part in (("before", items[:REBOOT_AT]), ("after", _clock_reset(items))):
        monitor, _ = make_monitor(name)
        subject = monitor.start_session("dev-1", "rae", "hammer_drill")
        for batch in part:
            monitor.ingest_many([batch], now=batch.device_time + 0.6)
        energy, seconds = energy + monitor.queries.day(subject, DAY).energy, seconds + monitor.queries.day(subject, DAY).seconds
    return energy, seconds


def _ingest(monitor, batches):
    for batch in batches:
        monitor.ingest_many([batch], now=batch.device_time + 0.6)


def test_a_reboot_that_resets_the_device_clock_counts_both_halves(make_monitor, clock, items, halves):
    monitor, sink = make_monitor()
    subject = monitor.start_session("dev-1", "rae", "hammer_drill")
    _ingest(monitor, items[:REBOOT_AT] + _clock_reset(items))
    day = monitor.queries.day(subject, DAY)
    assert day.energy == pytest.approx(halves[0], rel=1e-9) and day.seconds == pytest.approx(halves[1])
    assert day.seconds == pytest.approx(32.0)
    status = monitor.queries.stream_status("dev-1")
    assert status.get("duplicates", 0) == 0 and status.get("late", 0) == 0 and status["restarts"] == 1
    assert [e.data["reason"] for e in sink.events if e.kind == "hav.gap"] == ["device restarted"]


def test_after_a_clock_reset_a_replayed_batch_of_either_epoch_still_counts_once(make_monitor, clock, items, halves):
    after = _clock_reset(items)
    replayed = items[:REBOOT_AT] + after[:10] + items[3:6] + after[2:5] + items[REBOOT_AT - 1:REBOOT_AT] + after[10:]
    monitor, _ = make_monitor()
    subject = monitor.start_session("dev-1", "rae", "hammer_drill")
    _ingest(monitor, replayed)
    assert monitor.queries.day(subject, DAY).energy == pytest.approx(halves[0], rel=1e-9)
    status = monitor.queries.stream_status("dev-1")
    assert status["duplicates"] == 7 and status["restarts"] == 1


def test_a_clock_reset_onto_the_same_times_counts_when_the_device_announces_its_boot(make_monitor, clock, items):
    """A boot-relative clock repeats the old epoch's times exactly: only the boot id in the status tells a
    restart from a replay; without it the repeats stay duplicates (never double-counted)."""
    same_times = items[:REBOOT_AT] + _clock_reset(items, boot_offset=0.0)
    counted = {}
    for boot in (None, "boot-2"):
        monitor, _ = make_monitor(f"boot-{boot}")
        online = {"online": True, "worker": "rae", "tool": "hammer_drill"}
        monitor.on_status(status_topic("demo", "dev-1"), json.dumps({**online, "boot": "boot-1"}).encode())
        subject = monitor.queries.session("dev-1").subject
        _ingest(monitor, same_times[:REBOOT_AT])
        if boot:
            monitor.on_status(status_topic("demo", "dev-1"), json.dumps({**online, "boot": boot}).encode())
        _ingest(monitor, same_times[REBOOT_AT:] + items[REBOOT_AT - 2:REBOOT_AT])  # and two replays of the old epoch
        status = monitor.queries.stream_status("dev-1")
        counted[boot] = monitor.queries.day(subject, DAY).seconds, status.get("restarts", 0), status["duplicates"]
    assert counted[None] == (pytest.approx(18.0), 0, 30)  # 28 repeat old times: dropped, never added twice
    assert counted["boot-2"] == (pytest.approx(32.0), 1, 2)


def test_a_monitor_restart_across_a_clock_reset_loses_nothing_and_double_counts_nothing(make_monitor, clock, items,
                                                                                       halves):
    stream = items[:REBOOT_AT] + _clock_reset(items)
    for cut in (REBOOT_AT - 3, REBOOT_AT + 1, REBOOT_AT + 12):  # before, just after and well after the reboot
        first, _ = make_monitor(f"cut-{cut}")
        subject = first.start_session("dev-1", "rae", "hammer_drill")
        _ingest(first, stream[:cut])
        first.close()  # the process dies: QoS 1 redelivers the last four before the new ones
        second, _ = make_monitor(f"cut-{cut}")
        _ingest(second, stream[cut - 4:])
        assert second.queries.day(subject, DAY).energy == pytest.approx(halves[0], rel=1e-9), cut
        assert second.queries.stream_status("dev-1")["restarts"] == 1 and second.queries.stats["duplicates"] == 4, cut
