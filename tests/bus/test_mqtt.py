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
    assert monitor.queries.stats["mismatched"] == 3
    assert monitor.queries.session("w2") is None
    assert monitor.queries.session("w1").tool == "grinder"
    started = next(e for e in sink.events if e.kind == "hav.activity_started")
    assert started.source == "w1" and started.received is not None
    bus.close()
    w1.close()
    monitor.close()


def test_a_restarted_monitor_gets_what_was_published_while_it_was_away(broker, tmp_path):
    sink = ListSink()
    fs, t0 = 5000.0, time.time()
    sent = list(batches("w2", session_signal([("idle", 1), ("breaker", 5)], fs), fs, t0))
    first = HavMonitor(tmp_path, "secret", [sink], MonitorConfig(site="s"))
    bus = client(broker, "monitor", client_id="hav-monitor-s", session_expiry_s=600)
    first.attach(bus)
    bus.connect()  # returns after the SUBACKs of what attach asked for
    w2 = connect(broker, "w2")
    for item in sent[:4]:
        w2.publish(accel_topic("s", "w2"), encode_accel(item), qos=1, wait=True)
    wait_for(lambda: (first.queries.stream_status("w2") or {}).get("next_seq") == 4, "the first monitor taking 4 batches")
    bus.close()  # the monitor stops mid-shift ...
    first.close()
    for item in sent[2:]:  # ... the device keeps publishing (and repeats two batches it was unsure about)
        w2.publish(accel_topic("s", "w2"), encode_accel(item), qos=1, wait=True)
    second = HavMonitor(tmp_path, "secret", [sink], MonitorConfig(site="s"))
    bus = client(broker, "monitor", client_id="hav-monitor-s", session_expiry_s=600)
    second.attach(bus)
    bus.connect()
    wait_for(lambda: second.queries.stream_status("w2")["next_seq"] == len(sent), "the restarted monitor catching up")
    assert second.queries.stats["duplicates"] == 2
    assert "hav.activity_started" in sink.kinds()
    bus.close()
    w2.close()
    second.close()


def test_a_device_claiming_the_monitors_client_id_cannot_knock_it_off(broker):
    monitor = client(broker, "monitor", client_id="bim2rdt-hav-monitor-s", session_expiry_s=600)
    got = collect(monitor, "site/s/wearable/+/accel")
    monitor.connect()
    intruder = connect(broker, "w3", client_id="bim2rdt-hav-monitor-s")  # its own password, the monitor's id
    for k in range(16):
        intruder.publish(accel_topic("s", "w3"), b"%d" % k, qos=1, wait=True)
    wait_for(lambda: len(got) == 16, "the monitor receiving all 16 messages")
    assert monitor.disconnects == 0 and monitor.connected  # the broker bound the intruder's id to its username
    intruder.close()
    monitor.close()


def test_a_device_cannot_publish_on_another_site(broker):
    w1 = connect(broker, "w1")
    assert w1.publish(accel_topic("s", "w1"), b"here", qos=1, wait=True) == 0
    assert w1.publish(accel_topic("OTHER", "w1"), b"elsewhere", qos=1, wait=True) == NOT_AUTHORIZED
    assert w1.publish(status_topic("OTHER", "w1"), b"elsewhere", qos=1, wait=True) == NOT_AUTHORIZED
    w1.close()


def test_a_handler_that_raises_is_counted_and_the_network_thread_lives_on(broker):
    bus = connect(broker, "dashboard")
    got = []

    def handler(topic, payload):
        got.append(payload)
        raise ValueError("a bug in a handler")

    bus.subscribe("site/s/wearable/+/status", handler)
    w1 = connect(broker, "w1")
    for _ in range(3):
        w1.publish(status_topic("s", "w1"), b"{}", qos=1, wait=True)
    wait_for(lambda: len(got) >= 3, "three deliveries despite the raising handler")
    assert bus.handler_errors >= 3 and bus.alive
    w1.close()
    bus.close()


@pytest.mark.filterwarnings("ignore::pytest.PytestUnhandledThreadExceptionWarning")
def test_the_watchdog_sees_a_dead_network_thread(broker):
    bus = connect(broker, "dashboard")

    def fatal(topic, payload):
        raise SystemExit("not an Exception: kills paho's thread")

    bus.subscribe("site/s/wearable/+/status", fatal)
    w1 = connect(broker, "w1")
    w1.publish(status_topic("s", "w1"), b"{}", qos=1, wait=True)
    wait_for(lambda: not bus.alive, "the network thread dying")
    from bim2rdt.cli.hav import watch

    class Idle:
        failure = None

        def tick(self):
            return []

    with pytest.raises(BusError, match="network thread died"):
        watch(Idle(), bus, duration=5.0, max_offline=60.0, period_s=0.05)
    w1.close()
    bus.close()


def test_a_poison_message_queued_for_a_stopped_monitor_does_not_stop_its_restart(broker, tmp_path):
    fs, t0 = 5000.0, time.time()
    good = list(batches("w4", session_signal([("grinder", 2)], fs), fs, t0))
    config = MonitorConfig(site="s", commit_delay_s=0.05)
    first = HavMonitor(tmp_path, "secret", [], config)
    bus = client(broker, "monitor-poison", client_id="monitor-poison", session_expiry_s=600, manual_ack=True)
    first.attach(bus)
    bus.connect()
    bus.close()  # the monitor stops; the broker keeps its session and queues for it
    first.close()
    w4 = connect(broker, "w4")
    header = json.dumps({"device": "w4", "seq": 0, "t_ms": t0 * 1000, "fs": fs, "n": 4, "dtype": "int16",
                         "scale": 0.06, "full_scale": {}}).encode()  # a logged-in device's poison (issue 10)
    poison = b"HAV1" + len(header).to_bytes(2, "little") + header + bytes(24)
    w4.publish(accel_topic("s", "w4"), poison, qos=1, wait=True)
    for item in good:
        w4.publish(accel_topic("s", "w4"), encode_accel(item), qos=1, wait=True)
    for attempt in range(2):  # the restart works, and the poison is not delivered a second time
        monitor = HavMonitor(tmp_path, "secret", [], config)
        bus = client(broker, "monitor-poison", client_id="monitor-poison", session_expiry_s=600, manual_ack=True)
        monitor.attach(bus)
        bus.connect()  # SUBACK received: the poison delivered first did not stop the network thread
        if attempt == 0:
            wait_for(lambda: (monitor.queries.stream_status("w4") or {}).get("next_seq") == len(good), "the good batches")
        time.sleep(0.5)
        assert monitor.queries.malformed_messages()["w4"].count == 1 and bus.alive
        bus.close()
        monitor.close()
    w4.close()
