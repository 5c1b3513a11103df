"""The HAV stream's limits on a real nats-server: a message longer than any wearable sends is not stored, one
device's flood evicts only its own messages, and the stream follows the settings when it already exists."""

from __future__ import annotations

import asyncio

import pytest

from bim2rdt.bus.nats_broker import NatsServer
from bim2rdt.bus.nats_bus import StreamLimits
from bim2rdt.bus.partitions import STREAM
from bim2rdt.bus.topics import accel_topic
from tests.bus.conftest import NATS_DEVICES, NATS_MONITORS, SITE
from tests.bus.nats_helpers import received, wearable

SMALL = StreamLimits(max_bytes=4 * 2**20, max_msg_bytes=64 * 1024, devices=2)
"""4 MiB for 2 devices: each device subject keeps 10 messages of at most 64 KiB."""


def stream_config(server: NatsServer):
    """The HAV stream's configuration as the server has it."""
    import nats

    async def read():
        connection = await nats.connect(server.url, user="monitor", password=NATS_MONITORS["monitor"])
        try:
            return (await connection.jetstream().stream_info(STREAM)).config
        finally:
            await connection.close()

    return asyncio.run(read())


def publish(server: NatsServer, device: str, payloads: list[bytes]) -> None:
    bus = wearable(server, device)
    for payload in payloads:
        bus.publish(accel_topic(SITE, device), payload, qos=1, wait=True)
    bus.close()


def test_one_devices_flood_of_large_messages_leaves_another_devices_unread_batches_in_the_stream(tmp_path):
    assert SMALL.max_msgs_per_subject == 10
    with NatsServer(SITE, NATS_DEVICES, NATS_MONITORS, partitions=1, folder=tmp_path / "nats", limits=SMALL) as server:
        publish(server, "w2", [b"w2-%d" % i for i in range(8)])
        publish(server, "w1", [b"%05d" % i + bytes(60_000) for i in range(100)])  # 6 MB: more than the stream
        messages = received(server, SITE)[0]
    by_device = {device: [p for t, p in messages if t == accel_topic(SITE, device)] for device in ("w1", "w2")}
    assert by_device["w2"] == [b"w2-%d" % i for i in range(8)]
    assert [p[:5] for p in by_device["w1"]] == [b"%05d" % i for i in range(90, 100)]  # only its own oldest went


def test_a_message_longer_than_the_stream_allows_is_not_stored(tmp_path):
    with NatsServer(SITE, NATS_DEVICES, NATS_MONITORS, partitions=1, folder=tmp_path / "nats", limits=SMALL) as server:
        publish(server, "w1", [bytes(200_000), b"after"])
        messages = received(server, SITE)[0]
    assert [payload for _, payload in messages] == [b"after"]


def test_an_existing_stream_is_brought_to_the_settings_limits(tmp_path):
    from bim2rdt.bus.nats_bus import NatsBus

    with NatsServer(SITE, NATS_DEVICES, NATS_MONITORS, partitions=1, folder=tmp_path / "nats") as server:
        before = stream_config(server)
        wanted = StreamLimits(max_age_s=60.0, max_bytes=10**6, max_msg_bytes=16 * 1024, devices=4)
        NatsBus(server.url, "monitor", NATS_MONITORS["monitor"], SITE, limits=wanted).connect().close()
        after = stream_config(server)
    assert (before.max_bytes, before.max_age) == (8 * 2**30, 86400.0)
    assert (after.max_bytes, after.max_age, after.max_msg_size) == (10**6, 60.0, 16 * 1024)
    assert after.max_msgs_per_subject == wanted.max_msgs_per_subject == 10**6 // (4 * 3 * 16 * 1024)


def test_limits_that_cannot_hold_one_message_per_device_subject_are_refused_in_one_line():
    with pytest.raises(ValueError, match="raise stream_max_bytes"):
        StreamLimits(max_bytes=100_000, max_msg_bytes=64 * 1024, devices=2)
