"""The MQTT bus over paho-mqtt 2.x (``CallbackAPIVersion.VERSION2``, MQTT 5), same interface as LocalBus.

With ``session_expiry_s`` and a fixed ``client_id`` the broker keeps the subscription and queues QoS 1 messages
while the client is away (a restarted monitor gets what it missed; its de-duplication drops what it had).

Handlers run on paho's network thread, one message at a time, in arrival order; a handler that raises is logged
and counted (``handler_errors``), never allowed to stop that thread. With ``manual_ack=True`` a subscription
made with ``manual_ack=True`` gets a third argument, ``ack()``, and the broker's QoS 1 acknowledgement waits until
the handler calls it (after its commit): what a crash interrupts is redelivered. Other messages are acknowledged
after their handlers return. ``publish(..., wait=True)``
blocks until the broker's PUBACK and returns its reason code: 0 when accepted, 135 (not authorized) when the
broker's ACL refused it. ``connect`` and ``subscribe`` return once the broker acknowledged the subscriptions
(SUBACK), so a message published after they return reaches the handler; every wait is bounded by ``timeout_s``.
"""

from __future__ import annotations

import logging
import threading
import uuid
from collections.abc import Callable

import paho.mqtt.client as mqtt
from paho.mqtt.packettypes import PacketTypes
from paho.mqtt.properties import Properties

from bim2rdt.bus.topics import topic_matches
from bim2rdt.errors import Bim2RdtError

Handler = Callable[..., object]
_KEPT_ACKS = 4096
log = logging.getLogger(__name__)


class BusError(Bim2RdtError):
    """The broker could not be reached, refused our credentials, or did not answer in time."""


class MqttBus:
    """An MQTT client (paho) for the site event bus; :meth:`connect` connects it.

    Args:
        host: The broker's host.
        port: The broker's port.
        client_id: The MQTT client id; None makes a random ``bim2rdt-...`` one.
        username: The broker user; None connects anonymously.
        password: The user's password.
        will: (topic, payload) the broker publishes retained if this client vanishes.
        timeout_s: How long to wait for the broker's CONNACK, SUBACK and PUBACK, seconds.
        session_expiry_s: How long the broker keeps the session (and queues QoS 1 messages) after a
            disconnect, seconds; 0 starts clean.
        manual_ack: Let handlers acknowledge messages themselves (after their commit).
        mqtt_version: 5, or 3 for MQTT 3.1.1 (nats-server's MQTT listener; a clean session, no expiry).
    """

    def __init__(self, host: str, port: int, client_id: str | None = None, username: str | None = None,
                 password: str | None = None, will: tuple[str, bytes] | None = None, timeout_s: float = 10.0,
                 session_expiry_s: int = 0, manual_ack: bool = False, mqtt_version: int = 5):
        self.host, self.port, self.timeout_s, self.session_expiry_s = host, port, timeout_s, session_expiry_s
        self.mqtt_version = mqtt_version
        self.manual_ack, self.handler_errors, self.disconnects = manual_ack, 0, 0
        self._client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, manual_ack=manual_ack,
                                   protocol=mqtt.MQTTv5 if mqtt_version == 5 else mqtt.MQTTv311,
                                   client_id=client_id or f"bim2rdt-{uuid.uuid4().hex[:8]}")
        if username is not None:
            self._client.username_pw_set(username, password)
        if will is not None:
            self._client.will_set(will[0], will[1], qos=1, retain=True)
        self._handlers: list[tuple[str, Handler, int, bool]] = []
        self._connected = threading.Event()
        self._connect_reason: str | None = None
        self._acks: dict[int, threading.Event] = {}  # PUBACK and SUBACK by message id (one counter in paho)
        self._resubscribed: list[int] = []
        self._ack_codes: dict[int, int] = {}
        self._lock = threading.Lock()
        self._client.on_connect = self._on_connect
        self._client.on_message = self._on_message
        self._client.on_publish = self._on_publish
        self._client.on_subscribe = self._on_subscribe
        self._client.on_disconnect = self._on_disconnect
        self._client.max_inflight_messages_set(1000)

    def connect(self) -> MqttBus:
        """Connect, wait for the broker's CONNACK, and wait for the SUBACKs of earlier subscriptions.

        Returns:
            This bus, connected.

        Raises:
            BusError: The broker cannot be reached, refuses the connection, or does not answer in time.
        """
        properties = None
        if self.session_expiry_s:
            properties = Properties(PacketTypes.CONNECT)
            properties.SessionExpiryInterval = self.session_expiry_s
        v5 = {"clean_start": not self.session_expiry_s, "properties": properties} if self.mqtt_version == 5 else {}
        try:
            self._client.connect(self.host, self.port, keepalive=30, **v5)
        except OSError as error:
            raise BusError(f"cannot reach MQTT broker {self.host}:{self.port}: {error}") from error
        self._client.loop_start()
        if not self._connected.wait(self.timeout_s) or self._connect_reason is not None:
            self.close()
            raise BusError(f"MQTT broker {self.host}:{self.port} refused the connection: "
                           f"{self._connect_reason or 'no answer'}")
        for mid in list(self._resubscribed):
            self._await_ack(mid, "SUBACK", "the subscriptions")
        return self

    def subscribe(self, pattern: str, handler: Handler, qos: int = 1, manual_ack: bool = False) -> int:
        """Call ``handler(topic, payload)`` for every message matching ``pattern`` (on the network thread); on a
        ``manual_ack`` bus with ``manual_ack`` here, ``handler(topic, payload, ack)``. When connected, wait for
        the SUBACK.

        Args:
            pattern: An MQTT topic filter (``+`` and ``#`` wildcards).
            handler: Called with (topic, payload), or (topic, payload, ack) with manual acknowledgement.
            qos: The subscription's QoS.
            manual_ack: Acknowledge by calling ``ack`` (only on a ``manual_ack`` bus).

        Returns:
            The SUBACK's reason code (the granted QoS, >= 128 if refused); 0 when not connected yet.

        Raises:
            BusError: No SUBACK within ``timeout_s``.
        """
        self._handlers.append((pattern, handler, qos, manual_ack and self.manual_ack))
        if not self._connected.is_set():
            return 0
        return self._await_ack(self._client.subscribe(pattern, qos=qos)[1], "SUBACK", pattern)

    def publish(self, topic: str, payload: bytes, qos: int = 0, retain: bool = False, wait: bool = False) -> int:
        """Publish a message.

        Args:
            topic: The topic.
            payload: The message.
            qos: 0, 1 or 2.
            retain: Ask the broker to keep it for later subscribers.
            wait: With QoS >= 1, block until the broker's PUBACK.

        Returns:
            The PUBACK's reason code with ``wait``, else 0.

        Raises:
            BusError: paho refused the message, or no PUBACK within ``timeout_s``.
        """
        info = self._client.publish(topic, payload, qos=qos, retain=retain)  # never under our lock: paho calls
        if info.rc != mqtt.MQTT_ERR_SUCCESS:                                 # on_publish holding its own
            raise BusError(f"publish to {topic} failed: {mqtt.error_string(info.rc)}")
        if not wait or qos == 0:
            return 0
        return self._await_ack(info.mid, "PUBACK", topic)

    def _await_ack(self, mid: int, kind: str, what: str) -> int:
        """Block until the broker acknowledged message ``mid`` (at most ``timeout_s``); its reason code."""
        with self._lock:
            done = self._acks.setdefault(mid, threading.Event())
            if mid in self._ack_codes:
                done.set()
        if not done.wait(self.timeout_s):
            raise BusError(f"no {kind} from {self.host}:{self.port} for {what} within {self.timeout_s} s")
        with self._lock:
            self._acks.pop(mid, None)
            return self._ack_codes.pop(mid, 0)

    def drain(self, timeout_s: float | None = None) -> bool:
        """Wait until the broker acknowledged every QoS 1 message published so far (before a close, which would
        drop what is still in flight).

        Args:
            timeout_s: How long to wait, seconds; None uses the bus's ``timeout_s``.

        Returns:
            True when nothing is in flight, False if the time passed first.
        """
        import time

        deadline = time.monotonic() + (self.timeout_s if timeout_s is None else timeout_s)
        while getattr(self._client, "_out_messages", None) and time.monotonic() < deadline:  # paho 2.x: unacked
            time.sleep(0.01)
        return not getattr(self._client, "_out_messages", None)

    @property
    def alive(self) -> bool:
        """Whether paho's network thread still runs (it may be reconnecting): a watchdog reads this."""
        thread = getattr(self._client, "_thread", None)  # paho 2.x keeps its loop_start thread here
        return thread is not None and thread.is_alive()

    @property
    def connected(self) -> bool:
        """Whether the client is connected to the broker now."""
        return self._client.is_connected()

    def close(self) -> None:
        """Disconnect cleanly (a clean disconnect does not fire the last will)."""
        self._client.disconnect()
        self._client.loop_stop()

    def __enter__(self) -> MqttBus:
        return self.connect()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _on_connect(self, client, userdata, flags, reason_code, properties) -> None:
        if reason_code.is_failure:
            self._connect_reason = str(reason_code)
        else:
            self._resubscribed = [client.subscribe(pattern, qos=qos)[1] for pattern, _, qos, _ in self._handlers]
        self._connected.set()

    def _on_message(self, client, userdata, message) -> None:
        ack = _Ack(client, message.mid, message.qos) if self.manual_ack else None
        handed_over = False
        for pattern, handler, _, takes_ack in self._handlers:
            if not topic_matches(pattern, message.topic):
                continue
            try:
                handler(message.topic, message.payload, ack) if takes_ack else handler(message.topic, message.payload)
                handed_over |= takes_ack
            except Exception:  # never let a handler stop the network thread; the message is dead-lettered
                self.handler_errors += 1
                log.exception("handler for %s failed; message dropped", message.topic)
        if ack is not None and not handed_over:
            ack()

    def _on_disconnect(self, client, userdata, flags, reason_code, properties) -> None:
        if reason_code.is_failure:  # not our own clean disconnect: paho reconnects; count it for watchdogs
            self.disconnects += 1
            log.warning("disconnected from %s:%s: %s", self.host, self.port, reason_code)

    def _on_subscribe(self, client, userdata, mid, reason_codes, properties) -> None:
        self._on_publish(client, userdata, mid, reason_codes[0], properties)

    def _on_publish(self, client, userdata, mid, reason_code, properties) -> None:
        with self._lock:
            self._ack_codes[mid] = reason_code.value
            while len(self._ack_codes) > _KEPT_ACKS:  # nobody waits for most of them: keep the latest only
                self._ack_codes.pop(next(iter(self._ack_codes)))
            waiting = self._acks.get(mid)
            if waiting is not None:
                waiting.set()


class _Ack:
    """Acknowledges one received message (QoS 1 PUBACK) once, from any thread."""

    def __init__(self, client: mqtt.Client, mid: int, qos: int):
        self._client, self._mid, self._qos, self._done = client, mid, qos, False

    def __call__(self) -> None:
        if not self._done and self._qos > 0:
            self._done = True
            self._client.ack(self._mid, self._qos)
