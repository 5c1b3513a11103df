"""The site bus: event schemas, topics, an in-process bus (default) and MQTT over paho-mqtt 2.x."""

from bim2rdt.bus.event import Event
from bim2rdt.bus.local import LocalBus
from bim2rdt.bus.payloads import AccelBatch, PayloadError, decode_accel, encode_accel
from bim2rdt.bus.topics import accel_topic, device_of, events_topic, status_topic, topic_matches


def __getattr__(name: str):
    if name in ("MqttBus", "BusError"):  # paho is imported only when MQTT is used
        from bim2rdt.bus import mqtt

        return getattr(mqtt, name)
    raise AttributeError(name)


__all__ = ["AccelBatch", "BusError", "Event", "LocalBus", "MqttBus", "PayloadError", "accel_topic", "decode_accel",
           "device_of", "encode_accel", "events_topic", "status_topic", "topic_matches"]
