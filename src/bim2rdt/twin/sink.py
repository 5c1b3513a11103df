"""The HAV monitor's events into the twin's history: a durable sink (``outbox = "twin"``: the monitor queues its
events in its own store and delivers them from there, retrying while the twin is unavailable, see
:mod:`bim2rdt.safety.outbox`), which takes a group of events in one transaction (``emit_many``) and says which
queued events it already holds (``delivered``), so a redelivery never doubles one."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from bim2rdt.bus import Event
from bim2rdt.twin.records import SAFETY

if TYPE_CHECKING:
    from bim2rdt.twin.twin import DigitalTwin


class TwinSink:
    """Appends every safety event the monitor emits to the twin (``DigitalTwin.record_events``).

    Args:
        twin: The twin whose history takes the events.
    """

    outbox = "twin"

    def __init__(self, twin: DigitalTwin):
        self.twin = twin

    def emit(self, event: Event) -> None:
        """Record one safety event in the twin's history.

        Args:
            event: A bus event from the HAV monitor.
        """
        self.twin.record_event(event)

    def emit_many(self, events: Sequence[Event]) -> None:
        """Record a group of events in one transaction (all recorded, or none on an error).

        Args:
            events: Bus events from the HAV monitor.
        """
        self.twin.record_events(events)

    def delivered(self, events: Sequence[Event]) -> set[int]:
        """Tell which queued events the twin already holds, so a redelivery never doubles one.

        Args:
            events: Events from the monitor's outbox, each with ``data["outbox_id"]``.

        Returns:
            The ``outbox_id`` of those the twin already holds.
        """
        return recorded_outbox_ids(self.twin, events)


def recorded_outbox_ids(twin: DigitalTwin, events: Sequence[Event]) -> set[int]:
    """Which of ``events`` the twin's history already holds: a safety record with the same kind, source, time (to
    the microsecond) and outbox id. Only records from one second before the earliest event on are read.

    Args:
        twin: The twin whose history is searched.
        events: Events from the monitor's outbox, each with ``data["outbox_id"]``; times in seconds.

    Returns:
        The ``data["outbox_id"]`` of those already held.
    """
    wanted = {_key(e.kind, e.source, e.time, e.data.get("outbox_id")) for e in events}
    since = min(e.time for e in events) - 1.0 if events else None
    held = set()
    for record in twin.events(since=since, kinds=[SAFETY]):
        body = record.data if isinstance(record.data, dict) else {}
        data = body.get("data") if isinstance(body.get("data"), dict) else {}
        key = _key(body.get("kind"), body.get("source"), body.get("time"), data.get("outbox_id"))
        if key in wanted:
            held.add(key[3])
    return held


def _key(kind, source, when, outbox_id) -> tuple:
    return (kind, source, round(float(when), 6) if when is not None else None, outbox_id)
