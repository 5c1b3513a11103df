"""Through a real Mosquitto with the shipped config: passwords, the per-device ACL, last will, the monitor."""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time

import pytest

from bim2rdt.bus import MqttBus, accel_topic, encode_accel, status_topic
from bim2rdt.bus.mqtt import BusError
from bim2rdt.safety import HavMonitor, ListSink, MonitorConfig
from bim2rdt.sim.vibration import batches, session_signal

NOT_AUTHORIZED = 135


def client(broker, user: str, password: str | None = None, **kw) -> MqttBus:
    return MqttBus("127.0.0.1", broker.port, username=user, password=password or broker.users[user], **kw)


def connect(broker, user: str, password: str | None = None, **kw) -> MqttBus:
    return client(broker, user, password, **kw).connect()


def collect(bus: MqttBus, pattern: str) -> list:
    got: list = []
    assert bus.subscribe(pattern, lambda topic, payload: got.append((topic, payload))) < 128  # SUBACK received
    return got


def wait_for(predicate, what: str, timeout: float = 10.0) -> None:
    """Poll ``predicate`` until true; fail the test naming ``what`` did not happen (never hang)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return
        time.sleep(0.02)
    pytest.fail(f"{what} did not happen within {timeout} s")


def test_the_broker_is_not_the_system_one(broker):
    assert broker.port != 1883


def test_a_device_publishes_its_own_topic_but_cannot_publish_as_another(broker):
    monitor = connect(broker, "monitor")
    got = collect(monitor, "site/+/wearable/#")
    w1 = connect(broker, "w1")
    assert w1.publish(accel_topic("s", "w1"), b"mine", qos=1, wait=True) == 0
    assert w1.publish(accel_topic("s", "w2"), b"forged", qos=1, wait=True) == NOT_AUTHORIZED
    assert w1.publish(status_topic("s", "w2"), b"forged", qos=1, wait=True) == NOT_AUTHORIZED
    wait_for(lambda: len(got) >= 1, "the monitor receiving w1's own message")
    time.sleep(0.3)  # a forged message, had the broker let it through, would arrive in this window
    assert got == [("site/s/wearable/w1/accel", b"mine")]
    w1.close()
    monitor.close()


def test_wrong_passwords_and_anonymous_clients_are_refused(broker):
    with pytest.raises(BusError, match="refused"):
        connect(broker, "w1", password="not-the-password")
    with pytest.raises(BusError, match="refused"):
        MqttBus("127.0.0.1", broker.port).connect()


def test_a_device_cannot_read_other_devices(broker):
    w2 = connect(broker, "w2")
    got = collect(w2, "site/+/wearable/#")
    w1 = connect(broker, "w1")
    w1.publish(accel_topic("s", "w1"), b"private", qos=1, wait=True)
    time.sleep(0.3)  # a device reads nothing (ACL), so there is no event to wait for: a window for a leak
    assert got == []
    w1.close()
    w2.close()


def test_a_vanished_device_is_marked_offline_by_its_retained_last_will(broker):
    script = (
        "import os, time, paho.mqtt.client as m\n"
        "c = m.Client(m.CallbackAPIVersion.VERSION2, client_id='w2-dev')\n"
        f"c.username_pw_set('w2', '{broker.users['w2']}')\n"
        "c.will_set('site/s/wearable/w2/status', b'{\"online\": false}', qos=1, retain=True)\n"
        f"c.connect('127.0.0.1', {broker.port}); c.loop_start()\n"
        "c.publish('site/s/wearable/w2/status', b'{\"online\": true}', qos=1, retain=True).wait_for_publish(5)\n"
        "os._exit(0)\n")  # dies without DISCONNECT: the broker must publish the will
    subprocess.run([sys.executable, "-c", script], check=True, timeout=30)
    dashboard = connect(broker, "dashboard")
    got = collect(dashboard, "site/s/wearable/+/status")
    wait_for(lambda: any(json.loads(p) == {"online": False} for _, p in got), "the retained last will arriving")
    dashboard.close()


def test_the_monitor_over_mqtt_ignores_payloads_whose_device_is_not_the_topics(broker, tmp_path):
    sink = ListSink()
    monitor = HavMonitor(tmp_path, "secret", [sink], MonitorConfig(site="s"))
    bus = connect(broker, "monitor")
    monitor.attach(bus)  # returns after the SUBACKs
    w1 = connect(broker, "w1")
    w1.publish(status_topic("s", "w1"), json.dumps({"online": True, "worker": "nia", "tool": "grinder"}).encode(),
               qos=1, retain=True, wait=True)
    fs, t0 = 5000.0, time.time()
    signal = session_signal([("idle", 1), ("grinder", 4)], fs)
    sent = list(batches("w1", signal, fs, t0))
    forged = [b.__class__("w2", b.seq, b.device_time, b.fs, b.xyz, b.full_scale) for b in sent[:3]]
    for item in forged:  # w1 may publish on its own topic, but the payload claims to be w2
        w1.publish(accel_topic("s", "w1"), encode_accel(item), qos=1)
    for item in sent:
        w1.publish(accel_topic("s", "w1"), encode_accel(item), qos=1)
    wait_for(lambda: "hav.activity_started" in sink.kinds(), "an activity start from w1's batches")
    assert monitor.stats["mismatched"] == 3
    assert monitor.session("w2") is None
    assert monitor.session("w1").tool == "grinder"
    started = next(e for e in sink.events if e.kind == "hav.activity_started")
    assert started.source == "w1" and started.received is not None
    bus.close()
    w1.close()
    monitor.close()


def test_a_restarted_monitor_gets_what_was_published_while_it_was_away(broker, tmp_path):
    sink = ListSink()
    fs, t0 = 5000.0, time.time()
    sent = list(batches("w2", session_signal([("idle", 1), ("breaker", 5)], fs), fs, t0))
    first = HavMonitor(tmp_path, "secret", [sink], MonitorConfig(site="r"))
    bus = client(broker, "monitor", client_id="hav-monitor-r", session_expiry_s=600)
    first.attach(bus)
    bus.connect()  # returns after the SUBACKs of what attach asked for
    w2 = connect(broker, "w2")
    for item in sent[:4]:
        w2.publish(accel_topic("r", "w2"), encode_accel(item), qos=1, wait=True)
    wait_for(lambda: (first.stream_status("w2") or {}).get("next_seq") == 4, "the first monitor taking 4 batches")
    bus.close()  # the monitor stops mid-shift ...
    first.close()
    for item in sent[2:]:  # ... the device keeps publishing (and repeats two batches it was unsure about)
        w2.publish(accel_topic("r", "w2"), encode_accel(item), qos=1, wait=True)
    second = HavMonitor(tmp_path, "secret", [sink], MonitorConfig(site="r"))
    bus = client(broker, "monitor", client_id="hav-monitor-r", session_expiry_s=600)
    second.attach(bus)
    bus.connect()
    wait_for(lambda: second.stream_status("w2")["next_seq"] == len(sent), "the restarted monitor catching up")
    assert second.stats["duplicates"] == 2
    assert "hav.activity_started" in sink.kinds()
    bus.close()
    w2.close()
    second.close()
