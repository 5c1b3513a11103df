"""The in-process bus: the default when no broker is configured. Same interface as :class:`MqttBus`."""

from __future__ import annotations

from collections.abc import Callable

from bim2rdt.bus.topics import topic_matches

Handler = Callable[[str, bytes], None]


class LocalBus:
    """Synchronous publish/subscribe inside one process, with MQTT wildcards and retained messages."""

    def __init__(self) -> None:
        self._handlers: list[tuple[str, Handler]] = []
        self._retained: dict[str, bytes] = {}

    def connect(self) -> LocalBus:
        """Nothing to connect to in one process; for :class:`MqttBus` compatibility.

        Returns:
            This bus.
        """
        return self

    def subscribe(self, pattern: str, handler: Handler, qos: int = 1, manual_ack: bool = False) -> None:
        """Call ``handler(topic, payload)`` for every message matching ``pattern``; retained ones first.
        ``manual_ack`` is accepted for :class:`MqttBus` compatibility: nothing here is ever redelivered.

        Args:
            pattern: An MQTT topic filter (``+`` and ``#`` wildcards).
            handler: Called with (topic, payload).
            qos: Accepted for :class:`MqttBus` compatibility.
            manual_ack: Accepted for :class:`MqttBus` compatibility.
        """
        self._handlers.append((pattern, handler))
        for topic, payload in list(self._retained.items()):
            if topic_matches(pattern, topic):
                handler(topic, payload)

    def publish(self, topic: str, payload: bytes, qos: int = 0, retain: bool = False, wait: bool = False) -> int:
        """Deliver a message to every matching handler now, in this thread.

        Args:
            topic: The topic.
            payload: The message.
            qos: Accepted for :class:`MqttBus` compatibility.
            retain: Keep the message for later subscribers.
            wait: Accepted for :class:`MqttBus` compatibility.

        Returns:
            0 (MQTT reason code 'success').
        """
        if retain:
            self._retained[topic] = payload
        for pattern, handler in list(self._handlers):
            if topic_matches(pattern, topic):
                handler(topic, payload)
        return 0

    def close(self) -> None:
        """Drop every subscription."""
        self._handlers.clear()

    def __enter__(self) -> LocalBus:
        return self.connect()

    def __exit__(self, *exc: object) -> None:
        self.close()
