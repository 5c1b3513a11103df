"""Helpers of the NATS tests: wearables over MQTT 3.1.1, and what reached each partition of the stream."""

from __future__ import annotations

import time

from bim2rdt.bus.mqtt import MqttBus
from bim2rdt.bus.nats_bus import NatsBus


def wearable(server, device: str, password: str | None = None) -> MqttBus:
    """``device`` logged in to the server's MQTT listener as itself (MQTT 3.1.1)."""
    password = password if password is not None else server.layout.devices[device]
    return MqttBus("127.0.0.1", server.mqtt_port, client_id=device, username=device, password=password,
                   mqtt_version=3).connect()


def received(server, site: str, wait_s: float = 1.5, user: str = "monitor") -> dict[int, list[tuple[str, bytes]]]:
    """{partition: [(topic, payload), ...]} of everything in the stream for ``site``, read by throw-away
    consumers (a fresh durable name per call is not needed: each partition's consumer reads from the start)."""
    out: dict[int, list[tuple[str, bytes]]] = {}
    buses = []
    for k in range(server.layout.partitions):
        got = out.setdefault(k, [])
        bus = NatsBus(server.url, user, server.layout.monitors[user], site, partition=k,
                      partitions=server.layout.partitions)
        bus.subscribe("#", lambda topic, payload, got=got: got.append((topic, payload)))
        buses.append(bus.connect())
    time.sleep(wait_s)
    for bus in buses:
        bus.close()
    return out
