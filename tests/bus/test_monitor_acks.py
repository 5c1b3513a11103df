"""Over MQTT the monitor acknowledges a message only after committing it: a killed monitor loses nothing."""

from __future__ import annotations

import subprocess
import sys
import time

from bim2rdt.bus import MqttBus, accel_topic, encode_accel
from bim2rdt.safety import HavMonitor, ListSink, MonitorConfig
from bim2rdt.sim.vibration import batches, session_signal

from test_mqtt import connect, wait_for

MONITOR = """
import sys, time
from pathlib import Path
from bim2rdt.bus import MqttBus
from bim2rdt.safety import HavMonitor, MonitorConfig
monitor = HavMonitor(Path(sys.argv[1]), "secret", [], MonitorConfig(site="s", commit_batches=500, commit_delay_s=10))
bus = MqttBus("127.0.0.1", int(sys.argv[2]), client_id="hav-" + sys.argv[4], username=sys.argv[4],
              password=sys.argv[3], session_expiry_s=600, manual_ack=True)
monitor.attach(bus)
bus.connect()
print("ready", flush=True)
while True:
    time.sleep(0.05)
    print(len(monitor._subscriber._waiting), flush=True)
"""


def test_a_monitor_killed_before_its_group_commit_gets_the_messages_again(broker, tmp_path):
    fs, t0 = 5000.0, time.time()
    sent = list(batches("w1", session_signal([("idle", 1), ("grinder", 9)], fs), fs, t0))  # 20 batches
    child = subprocess.Popen([sys.executable, "-c", MONITOR, str(tmp_path), str(broker.port),
                              broker.users["monitor-acks"], "monitor-acks"], stdout=subprocess.PIPE, text=True)
    try:
        assert child.stdout.readline().strip() == "ready"
        w1 = connect(broker, "w1")
        for item in sent:
            w1.publish(accel_topic("s", "w1"), encode_accel(item), qos=1, wait=True)
        while int(child.stdout.readline()) < len(sent):  # all received, none committed (group of 500, 10 s)
            pass
        child.kill()  # no flush, no DISCONNECT: the PUBACKs were never sent
        child.wait(timeout=10)
    finally:
        if child.poll() is None:
            child.kill()
    sink = ListSink()
    monitor = HavMonitor(tmp_path, "secret", [sink], MonitorConfig(site="s", commit_delay_s=0.05))
    assert monitor.queries.stream_status("w1") is None  # nothing had been committed ...
    bus = MqttBus("127.0.0.1", broker.port, client_id="hav-monitor-acks", username="monitor-acks",
                  password=broker.users["monitor-acks"], session_expiry_s=600, manual_ack=True)
    monitor.attach(bus)
    bus.connect()
    wait_for(lambda: (monitor.queries.stream_status("w1") or {}).get("next_seq") == len(sent), "redelivery of all 20")
    assert monitor.queries.stats.get("duplicates", 0) == 0  # ... and nothing is counted twice
    assert "hav.activity_started" in sink.kinds()
    bus.close()
    w1.close()
    monitor.close()


def test_without_manual_acks_the_same_kill_loses_the_waiting_group(broker, tmp_path):
    """The counterpart: paho's automatic PUBACK on receipt, as before the group commit's manual acks."""
    script = MONITOR.replace("manual_ack=True", "manual_ack=False")
    child = subprocess.Popen([sys.executable, "-c", script, str(tmp_path), str(broker.port),
                              broker.users["monitor-auto"], "monitor-auto"], stdout=subprocess.PIPE, text=True)
    fs, t0 = 5000.0, time.time()
    sent = list(batches("w2", session_signal([("grinder", 5)], fs), fs, t0))
    try:
        assert child.stdout.readline().strip() == "ready"
        w2 = connect(broker, "w2")
        for item in sent:
            w2.publish(accel_topic("s", "w2"), encode_accel(item), qos=1, wait=True)
        while int(child.stdout.readline()) < len(sent):
            pass
        child.kill()
        child.wait(timeout=10)
    finally:
        if child.poll() is None:
            child.kill()
    monitor = HavMonitor(tmp_path, "secret", [], MonitorConfig(site="s", commit_delay_s=0.05))
    bus = MqttBus("127.0.0.1", broker.port, client_id="hav-monitor-auto", username="monitor-auto",
                  password=broker.users["monitor-auto"], session_expiry_s=600).connect()
    monitor.attach(bus)
    time.sleep(1.0)  # nothing is queued for us: there is nothing to wait for
    assert monitor.queries.stream_status("w2") is None
    bus.close()
    w2.close()
    monitor.close()
