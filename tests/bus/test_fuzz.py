"""Fuzzing the monitor's bus input (issue 10, section 1): thousands of hostile messages, none raises, each is
counted, and a good stream interleaved with them gives exactly the A(8) it gives alone. Bounded: a fixed number
of derandomized examples, no example database, so `make test` stays reproducible."""

from __future__ import annotations

import json
import os
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from contextlib import closing
from datetime import datetime, timezone
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bim2rdt.bus import MqttBus, accel_topic, decode_accel, encode_accel, status_topic
from bim2rdt.safety import HavMonitor, MonitorConfig
from bim2rdt.sim.vibration import batches, session_signal

from poison import BAD_STATUS, poison_accel

FUZZ = settings(deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.function_scoped_fixture, HealthCheck.filter_too_much])
T0 = 1_700_000_000.0
DAY = "2023-11-14"
ACCEL, STATUS = accel_topic("demo", "w1"), status_topic("demo", "w1")


def _good(device: str, t0: float, seconds: float = 10.0) -> list:
    """A hammer-drill stream as the monitor receives it (int16 on the wire)."""
    fs = 5000.0
    signal_ = session_signal([("idle", 1), ("hammer_drill", seconds - 1)], fs, a_hv={"hammer_drill": 12.0})
    return [decode_accel(encode_accel(b)) for b in batches(device, signal_, fs, t0)]


GOOD = _good("w1", T0)


def _reference_energy(good: list) -> float:
    monitor = HavMonitor(None, "fuzz", [], MonitorConfig(), clock=lambda: T0)
    subject = monitor.start_session("w1", "fay", "hammer_drill")
    monitor.ingest_many(good, now=T0 + 100)
    energy = monitor.queries.day(subject, DAY).energy
    monitor.close()
    return energy


REFERENCE = _reference_energy(GOOD)


@pytest.fixture(scope="module")
def target():
    monitor = HavMonitor(None, "fuzz", [], MonitorConfig(), clock=lambda: T0)
    yield monitor
    monitor.close()


@settings(FUZZ, max_examples=2500)
@given(message=st.one_of(poison_accel.map(lambda p: (ACCEL, p)), BAD_STATUS.map(lambda p: (STATUS, p))))
def test_thousands_of_hostile_messages_never_raise_and_each_is_counted(target, message):
    topic, payload = message
    before = target.queries.malformed_messages().get("w1")
    handled = target.ingest_payload(topic, payload) if topic == ACCEL else target.on_status(topic, payload)
    assert handled == []
    assert target.queries.malformed_messages()["w1"].count == (before.count if before else 0) + 1
    assert target.queries.devices() == [] and target.queries.session("w1") is None


@settings(FUZZ, max_examples=25)
@given(slots=st.lists(st.lists(st.one_of(poison_accel.map(lambda p: (ACCEL, p)),
                                         BAD_STATUS.map(lambda p: (STATUS, p))), max_size=6),
                      min_size=len(GOOD), max_size=len(GOOD)))
def test_a_good_stream_interleaved_with_poison_gives_its_own_a8(slots):
    monitor = HavMonitor(None, "fuzz", [], MonitorConfig(), clock=lambda: T0 + 100)
    subject = monitor.start_session("w1", "fay", "hammer_drill")
    for batch, poison in zip(GOOD, slots):
        for topic, payload in poison:
            monitor.ingest_payload(topic, payload) if topic == ACCEL else monitor.on_status(topic, payload)
        monitor.ingest_payload(ACCEL, encode_accel(batch))
    assert monitor.queries.day(subject, DAY).energy == pytest.approx(REFERENCE, rel=1e-9)
    refused = monitor.queries.malformed_messages().get("w1")
    assert (refused.count if refused else 0) == sum(len(poison) for poison in slots)
    monitor.close()


def test_a_live_listener_through_mosquitto_survives_thousands_of_hostile_messages(broker, tmp_path):
    site, device, t0 = "s", "w5", time.time()
    good = _good(device, t0, seconds=12.0)
    env = {**os.environ, "BIM2RDT_DATA_DIR": str(tmp_path), "BIM2RDT_MQTT__SITE": site, "PYTHONUNBUFFERED": "1",
           "BIM2RDT_MQTT__USERNAME": "monitor-fuzz", "BIM2RDT_MQTT__PASSWORD": broker.users["monitor-fuzz"],
           "BIM2RDT_HAV__SITE_SECRET": "fuzz-site"}
    listener = subprocess.Popen([sys.executable, "-m", "bim2rdt", "hav", "listen", "--mqtt",
                                 f"127.0.0.1:{broker.port}"], env=env, stdout=subprocess.PIPE,
                                stderr=subprocess.DEVNULL, text=True)
    out = _follow(listener, "listening on")
    w5 = MqttBus("127.0.0.1", broker.port, username=device, password=broker.users[device]).connect()
    accel, status = accel_topic(site, device), status_topic(site, device)
    w5.publish(status, json.dumps({"online": True, "worker": "fay", "tool": "hammer_drill"}).encode(), qos=1,
               wait=True)
    sent = {"poison": 0, "good": 0}

    @settings(FUZZ, max_examples=24)
    @given(poison=st.lists(st.one_of(poison_accel.map(lambda p: (accel, _as(p, device))),
                                     BAD_STATUS.map(lambda p: (status, p))), min_size=40, max_size=80))
    def publish_round(poison):
        for topic, payload in poison:
            w5.publish(topic, payload, qos=1)
        sent["poison"] += len(poison)
        if sent["good"] < len(good):
            w5.publish(accel, encode_accel(good[sent["good"]]), qos=1)
            sent["good"] += 1

    publish_round()
    for batch in good[sent["good"]:]:
        w5.publish(accel, encode_accel(batch), qos=1)
    w5.publish(status, b'{"online": false}', qos=1, wait=True)
    w5.close()
    _wait_for_refused(tmp_path / "hav" / "hav.sqlite", device, sent["poison"])  # a loaded listener lags the broker
    time.sleep(2.0)  # the good batches after the poison, the last group commit (0.25 s) and the offline status
    listener.send_signal(signal.SIGINT)  # a clean stop: flush, summary, exit 0
    assert listener.wait(timeout=60) == 0
    text = "".join(out)
    assert "Refused messages" in text and device in text

    monitor = HavMonitor(tmp_path / "hav", "fuzz-site", [], MonitorConfig(site=site))
    day = datetime.fromtimestamp(t0, timezone.utc).strftime("%Y-%m-%d")
    subject = monitor.queries.session(device).subject
    reference = HavMonitor(None, "fuzz-site", [], MonitorConfig(site=site), clock=lambda: t0)
    reference.start_session(device, "fay", "hammer_drill")
    reference.ingest_many(good, now=t0 + 100)
    assert sent["poison"] >= 1000
    assert monitor.queries.malformed_messages()[device].count == sent["poison"]
    assert monitor.queries.day(subject, day).energy == pytest.approx(reference.queries.day(subject, day).energy, rel=1e-9)
    reference.close()
    monitor.close()


def _as(payload: bytes, device: str) -> bytes:
    """The w1-based poison, for ``device``'s topic (same length, so the framing stays as hostile)."""
    return payload.replace(b'"w1"', b'"' + device.encode() + b'"')


def _wait_for_refused(store: Path, device: str, count: int, timeout: float = 60.0) -> None:
    """Until the listener's store (SQLite in WAL mode, read here read-only beside it) has committed ``count``
    refused messages of ``device``, or ``timeout`` s pass; the test's own assertion then reads the count."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            with closing(sqlite3.connect(f"file:{store}?mode=ro", uri=True, timeout=1.0)) as db:
                row = db.execute("SELECT count FROM malformed WHERE device = ?", (device,)).fetchone()
        except sqlite3.OperationalError:  # not created yet, or busy at a checkpoint
            row = None
        if row is not None and row[0] >= count:
            return
        time.sleep(0.25)


def _follow(process: subprocess.Popen, text: str, timeout: float = 30.0) -> list[str]:
    lines, seen = [], threading.Event()

    def read() -> None:
        for line in process.stdout:
            lines.append(line)
            if text in line:
                seen.set()

    threading.Thread(target=read, daemon=True).start()
    if not seen.wait(timeout):
        process.kill()
        pytest.fail(f"no {text!r} within {timeout} s: {''.join(lines)[-300:]!r}")
    return lines
