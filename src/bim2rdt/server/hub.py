"""The live stream's fan-out: messages published from any thread reach every subscriber's queue on the event loop.

The HAV monitor emits its events from the bus thread right after their commit; ``Hub.publish`` numbers each
message, keeps it in a backlog (so a client that reconnects with ``Last-Event-ID`` gets what it missed) and hands
it to the loop with ``call_soon_threadsafe``: no polling between the monitor and the stream. A subscriber whose
queue overflows (a client that stopped reading) is dropped; it reconnects and replays from the backlog.
"""

from __future__ import annotations

import asyncio
import itertools
import json
import threading
import time
from collections import deque
from dataclasses import dataclass
from typing import Any

from bim2rdt.bus import Event


@dataclass(frozen=True)
class Message:
    """One stream message: ``id`` (1, 2, ... in publish order), ``kind`` (the SSE event name), JSON-ready
    ``data`` and ``sent`` (UTC epoch seconds when it was published: clients measure delivery latency by it)."""

    id: int
    kind: str
    data: Any
    sent: float

    def encode(self) -> bytes:
        """The message as one server-sent event."""
        body = json.dumps({"id": self.id, "kind": self.kind, "sent": self.sent, "data": self.data},
                          separators=(",", ":"), default=_plain, allow_nan=False)
        return f"id: {self.id}\nevent: {self.kind}\ndata: {body}\n\n".encode("utf-8")


class Subscription:
    """One client's queue; ``lost`` is set when it overflowed."""

    def __init__(self, size: int):
        self.queue: asyncio.Queue[Message] = asyncio.Queue(size)
        self.lost = asyncio.Event()

    def offer(self, message: Message) -> None:
        try:
            self.queue.put_nowait(message)
        except asyncio.QueueFull:
            self.lost.set()


class Hub:
    """Numbered messages fanned out to subscribers; thread-safe ``publish``."""

    def __init__(self, backlog: int = 2000, queue_size: int = 1000):
        self._ids = itertools.count(1)
        self._backlog: deque[Message] = deque(maxlen=backlog)
        self._subscribers: set[Subscription] = set()
        self._latest: dict[str, Message] = {}
        self._lock = threading.Lock()
        self._loop: asyncio.AbstractEventLoop | None = None
        self.queue_size = queue_size

    def bind(self, loop: asyncio.AbstractEventLoop) -> None:
        """The loop the subscribers live on (the server's, at startup)."""
        self._loop = loop

    def publish(self, kind: str, data: Any) -> Message:
        """Number and keep a message, and send it to every subscriber; callable from any thread."""
        with self._lock:
            message = Message(next(self._ids), kind, data, time.time())
            self._backlog.append(message)
            self._latest[kind] = message
        loop = self._loop
        if loop is not None and not loop.is_closed():
            try:
                loop.call_soon_threadsafe(self._fan_out, message)
            except RuntimeError:  # the loop closed between the check and the call (server shutting down)
                pass
        return message

    def subscribe(self, last_id: int | None = None, snapshots: tuple[str, ...] = ()) -> Subscription:
        """A new subscriber (on the loop's thread); with ``last_id``, the backlog after it is queued first, else
        the newest message of each kind in ``snapshots`` (a state such as the workers' exposure)."""
        subscription = Subscription(self.queue_size)
        with self._lock:
            if last_id is None:
                missed = sorted((self._latest[k] for k in snapshots if k in self._latest), key=lambda m: m.id)
            else:
                missed = [m for m in self._backlog if m.id > last_id]
        for message in missed:
            subscription.offer(message)
        self._subscribers.add(subscription)
        return subscription

    def unsubscribe(self, subscription: Subscription) -> None:
        self._subscribers.discard(subscription)

    @property
    def subscribers(self) -> int:
        return len(self._subscribers)

    @property
    def last_id(self) -> int:
        with self._lock:
            return self._backlog[-1].id if self._backlog else 0

    def _fan_out(self, message: Message) -> None:
        for subscription in list(self._subscribers):
            subscription.offer(message)


class HubSink:
    """A HAV monitor sink (``emit(event)``): each safety event goes on the stream as ``safety``."""

    def __init__(self, hub: Hub):
        self.hub = hub

    def emit(self, event: Event) -> None:
        self.hub.publish("safety", event_record(event))


def event_record(event: Event) -> dict:
    """A bus event as JSON-ready data (non-finite numbers, e.g. an infinite time to EAV, become None)."""
    return {"kind": event.kind, "time": event.time, "subject": event.subject, "source": event.source,
            "data": _finite(event.data), "received": event.received}


def _finite(value: Any) -> Any:
    if isinstance(value, float):
        return value if value == value and abs(value) != float("inf") else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    return value


def _plain(value: Any) -> Any:
    if hasattr(value, "tolist"):
        return value.tolist()
    return str(value)
