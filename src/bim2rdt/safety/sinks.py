"""Where the monitor's events go: strategies with one method, ``emit(event)``; the monitor loop has no ifs.

``ListSink`` keeps them (tests, the analyze command), ``BusSink`` publishes them as JSON on
``site/{site}/safety/events``, ``CallbackSink`` hands them to a function (the CLI's live table). The IFC sink
that turns them into IfcEvent/IfcTask records lives in :mod:`bim2rdt.safety.ifc_sink`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from bim2rdt.bus.event import Event
from bim2rdt.bus.topics import events_topic


class EventSink(Protocol):
    def emit(self, event: Event) -> None: ...


class ListSink:
    """Keeps every event in ``events``, in order."""

    def __init__(self) -> None:
        self.events: list[Event] = []

    def emit(self, event: Event) -> None:
        self.events.append(event)

    def kinds(self) -> list[str]:
        return [e.kind for e in self.events]


class CallbackSink:
    """Calls ``callback(event)`` for each event."""

    def __init__(self, callback: Callable[[Event], None]):
        self.callback = callback

    def emit(self, event: Event) -> None:
        self.callback(event)


class BusSink:
    """Publishes each event as JSON, QoS 1, on the site's safety topic of a LocalBus or MqttBus."""

    def __init__(self, bus, site: str):
        self.bus, self.topic = bus, events_topic(site)

    def emit(self, event: Event) -> None:
        self.bus.publish(self.topic, event.to_json(), qos=1)
