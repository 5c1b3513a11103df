"""The site bus: event schemas, topics, an in-process bus (default) and MQTT over paho-mqtt 2.x."""

from bim2rdt.bus.event import Event
from bim2rdt.bus.local import LocalBus
from bim2rdt.bus.partitions import partition_of
from bim2rdt.bus.payloads import MAX_BATCH_S, AccelBatch, PayloadError, decode_accel, decode_status, encode_accel
from bim2rdt.bus.summaries import DeviceSummary, decode_summary
from bim2rdt.bus.topics import accel_topic, device_of, events_topic, status_topic, topic_matches, wearable_pattern


def __getattr__(name: str):
    if name in ("MqttBus", "BusError"):  # paho is imported only when MQTT is used
        from bim2rdt.bus import mqtt

        return getattr(mqtt, name)
    if name == "NatsBus":  # nats-py is imported only when NATS is used
        from bim2rdt.bus import nats_bus

        return nats_bus.NatsBus
    raise AttributeError(name)


__all__ = ["accel_topic", "AccelBatch", "BusError", "decode_accel", "decode_status", "decode_summary", "device_of",
           "DeviceSummary", "encode_accel", "Event", "events_topic", "LocalBus", "MAX_BATCH_S", "MqttBus", "NatsBus",
           "partition_of", "PayloadError", "status_topic", "topic_matches", "wearable_pattern"]
