"""A lean MQTT 3.1.1 publisher for many wearables in one thread: the benchmark's load generator.

On a 2-core machine the wearables' publishing takes CPU from the monitors being measured (on a site each wearable
is a device of its own). paho runs a network thread per client and builds each packet in Python; this writes
pre-framed QoS 1 PUBLISH packets on one blocking socket per device and counts the PUBACKs. It speaks the protocol the wearables speak (CONNECT with the device's
user and password, PUBLISH QoS 1, PUBACK), so the broker's MQTT listener, its permissions and JetStream see what
they see from paho.
"""

from __future__ import annotations

import selectors
import socket
import struct
import time

CONNECT, CONNACK, PUBLISH_QOS1, PUBACK, DISCONNECT = 0x10, 0x20, 0x32, 0x40, 0xE0


class MqttFleetError(RuntimeError):
    """The broker refused a wearable, closed its connection, or did not acknowledge in time."""


def remaining_length(size: int) -> bytes:
    """MQTT's variable-length encoding of a packet's remaining length."""
    out = bytearray()
    while True:
        size, digit = divmod(size, 128)
        out.append(digit | (0x80 if size else 0))
        if not size:
            return bytes(out)


def _text(value: str) -> bytes:
    data = value.encode()
    return struct.pack("!H", len(data)) + data


def connect_packet(client_id: str, username: str, password: str, keepalive_s: int = 60) -> bytes:
    """CONNECT, protocol level 4 (3.1.1), clean session, with user and password."""
    body = _text("MQTT") + bytes([4, 0xC2]) + struct.pack("!H", keepalive_s)
    body += _text(client_id) + _text(username) + _text(password)
    return bytes([CONNECT]) + remaining_length(len(body)) + body


def publish_packet(topic: str, payload: bytes, packet_id: int) -> bytes:
    """PUBLISH at QoS 1 with ``packet_id`` (1..65535)."""
    body = _text(topic) + struct.pack("!H", packet_id)
    return bytes([PUBLISH_QOS1]) + remaining_length(len(body) + len(payload)) + body + payload


class _Wearable:
    __slots__ = ("sock", "next_id", "unacked", "inbox")

    def __init__(self, sock: socket.socket):
        self.sock, self.next_id, self.unacked, self.inbox = sock, 1, 0, b""


class MqttFleet:
    """One MQTT 3.1.1 connection per device to ``host:port``; ``publish`` writes a QoS 1 message on the device's
    connection; ``drain`` waits for every PUBACK."""

    def __init__(self, host: str, port: int, credentials: dict[str, str], timeout_s: float = 10.0):
        self.host, self.port, self.credentials, self.timeout_s = host, port, credentials, timeout_s
        self._wearables: dict[str, _Wearable] = {}
        self._selector = selectors.DefaultSelector()

    def __enter__(self) -> MqttFleet:
        try:
            for device, password in self.credentials.items():
                self._wearables[device] = self._connect(device, password)
        except BaseException:  # a refused or unreachable wearable: the ones connected before it are closed too
            self.close()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def publish(self, device: str, topic: str, payload: bytes) -> None:
        """Write one QoS 1 PUBLISH on ``device``'s connection (reading the PUBACKs that are waiting first)."""
        wearable = self._wearables[device]
        self._read_acks(0.0)
        wearable.sock.sendall(publish_packet(topic, payload, wearable.next_id))
        wearable.next_id = wearable.next_id % 65535 + 1
        wearable.unacked += 1

    def drain(self, timeout_s: float = 60.0) -> None:
        """Wait until the broker acknowledged every message published; MqttFleetError when it does not in time."""
        deadline = time.monotonic() + timeout_s
        while any(w.unacked for w in self._wearables.values()):
            if time.monotonic() > deadline:
                waiting = sum(w.unacked for w in self._wearables.values())
                raise MqttFleetError(f"{waiting} messages unacknowledged after {timeout_s:.0f} s")
            self._read_acks(0.05)

    def close(self) -> None:
        for wearable in self._wearables.values():
            try:
                wearable.sock.sendall(bytes([DISCONNECT, 0]))
            except OSError:
                pass
            self._selector.unregister(wearable.sock)
            wearable.sock.close()
        self._wearables.clear()
        self._selector.close()

    def _connect(self, device: str, password: str) -> _Wearable:
        sock = socket.create_connection((self.host, self.port), self.timeout_s)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        sock.sendall(connect_packet(device, device, password))
        reply = _receive(sock, 4)
        if reply[0] != CONNACK or reply[3] != 0:
            sock.close()
            raise MqttFleetError(f"the broker refused wearable {device!r} (CONNACK return code {reply[3]})")
        wearable = _Wearable(sock)
        self._selector.register(sock, selectors.EVENT_READ, wearable)
        return wearable

    def _read_acks(self, timeout_s: float) -> None:
        for key, _ in self._selector.select(timeout_s):
            wearable: _Wearable = key.data
            data = wearable.sock.recv(65536)
            if not data:
                raise MqttFleetError("the broker closed a wearable's connection")
            inbox = wearable.inbox + data
            whole = len(inbox) - len(inbox) % 4
            for i in range(0, whole, 4):
                if inbox[i] != PUBACK:
                    raise MqttFleetError(f"unexpected MQTT packet type 0x{inbox[i]:02x} from the broker")
            wearable.unacked -= whole // 4
            wearable.inbox = inbox[whole:]


def _receive(sock: socket.socket, size: int) -> bytes:
    data = b""
    while len(data) < size:
        chunk = sock.recv(size - len(data))
        if not chunk:
            raise MqttFleetError("the broker closed the connection")
        data += chunk
    return data
