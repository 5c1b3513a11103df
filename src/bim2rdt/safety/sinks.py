"""Where the monitor's events go: strategies with one method, ``emit(event)``; the monitor loop has no ifs.
A sink that gains from groups also has ``emit_many(events)``: :func:`emit_all` hands it each commit's events in one
call (the twin's sink records them in one transaction), and every other sink one event at a time.

``ListSink`` keeps them (tests, the analyze command), ``BusSink`` publishes them as JSON on
``site/{site}/safety/events``, ``CallbackSink`` hands them to a function (the CLI's live table). The IFC sink
that turns them into IfcEvent/IfcTask records lives in :mod:`bim2rdt.safety.ifc_sink`.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Sequence
from typing import TYPE_CHECKING, Protocol

from bim2rdt.bus import Event
from bim2rdt.bus import events_topic

if TYPE_CHECKING:
    from bim2rdt.bus import LocalBus, MqttBus


class EventSink(Protocol):
    """Where the monitor's events go: anything with ``emit(event)`` (and optionally ``emit_many(events)``)."""

    def emit(self, event: Event) -> None:
        """Take one event.

        Args:
            event: A monitor event.
        """
        ...


def emit_all(sinks: Iterable[EventSink], events: Sequence[Event]) -> None:
    """Hand one commit's events to each sink in turn, in order: in one ``emit_many`` call to a sink that has it,
    else one ``emit`` per event."""
    if not events:
        return
    for sink in sinks:
        many = getattr(sink, "emit_many", None)
        if many is not None:
            many(events)
            continue
        for event in events:
            sink.emit(event)


def emit_each(sinks: Iterable[EventSink], events: Sequence[Event]) -> int:
    """:func:`emit_all`, each sink on its own: one that raises is logged and skipped, the others still get the
    events; returns how many sinks failed (a sink's failure says nothing about the messages)."""
    failed = 0
    for sink in sinks:
        try:
            emit_all([sink], events)
        except Exception:
            failed += 1
            logging.getLogger("bim2rdt.safety").exception("the sink %s failed on %d events", type(sink).__name__,
                                                          len(events))
    return failed


class ListSink:
    """Keeps every event in ``events``, in order."""

    def __init__(self) -> None:
        self.events: list[Event] = []

    def emit(self, event: Event) -> None:
        """Keep one event.

        Args:
            event: A monitor event.
        """
        self.events.append(event)

    def kinds(self) -> list[str]:
        """The kinds of the kept events.

        Returns:
            Their kinds, in order.
        """
        return [e.kind for e in self.events]


class CallbackSink:
    """Calls ``callback(event)`` for each event.

    Args:
        callback: Called with each event.
    """

    def __init__(self, callback: Callable[[Event], None]):
        self.callback = callback

    def emit(self, event: Event) -> None:
        """Hand one event to the callback.

        Args:
            event: A monitor event.
        """
        self.callback(event)


class BusSink:
    """Publishes each event as JSON, QoS 1, on the site's safety topic of a LocalBus or MqttBus.

    Args:
        bus: The site event bus.
        site: The site id of the topic ``site/{site}/safety/events``.
    """

    def __init__(self, bus: LocalBus | MqttBus, site: str):
        self.bus, self.topic = bus, events_topic(site)

    def emit(self, event: Event) -> None:
        """Publish one event.

        Args:
            event: A monitor event.
        """
        self.bus.publish(self.topic, event.to_json(), qos=1)
