"""The benchmark's lean wearables (one thread, pre-framed MQTT 3.1.1 packets) speak the protocol nats-server's MQTT
listener and its per-device permissions expect: what they publish lands in the stream as paho's would."""

from __future__ import annotations

import pytest

from bim2rdt.bench.mqtt_fleet import MqttFleet, MqttFleetError, remaining_length
from bim2rdt.bus.topics import accel_topic

from tests.bus.conftest import NATS_DEVICES, SITE
from tests.bus.nats_helpers import received


@pytest.mark.parametrize("size, encoded", [(0, "00"), (127, "7f"), (128, "8001"), (16383, "ff7f"),
                                           (16384, "808001"), (2_097_151, "ffff7f")])
def test_remaining_length_is_mqtts_variable_length_integer(size, encoded):
    assert remaining_length(size).hex() == encoded


def test_the_fleet_publishes_each_devices_messages_into_the_stream(nats_server):
    sent = [(device, accel_topic(SITE, device), bytes([k]) * (200 + 7000 * k)) for k in range(3)
            for device in ("w1", "w2", "w4")]
    with MqttFleet("127.0.0.1", nats_server.mqtt_port, {d: NATS_DEVICES[d] for d in ("w1", "w2", "w4")}) as fleet:
        for device, topic, payload in sent:
            fleet.publish(device, topic, payload)
        fleet.drain(10.0)
    got = sorted(item for items in received(nats_server, SITE).values() for item in items)
    assert got == sorted((topic, payload) for _, topic, payload in sent)  # 200 B to 14 kB, each once


def test_a_wrong_password_is_refused_in_one_line_and_the_connected_wearables_are_closed(nats_server):
    fleet = MqttFleet("127.0.0.1", nats_server.mqtt_port, {"w2": NATS_DEVICES["w2"], "w1": "not-its-password"})
    with pytest.raises(MqttFleetError, match=r"^the broker refused wearable 'w1' \(CONNACK return code [45]\)$"):
        with fleet:
            pass
    assert fleet._wearables == {}  # w2 connected first, and was closed
