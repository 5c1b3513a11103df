"""The HAV monitor's events into the twin's history: a sink (``emit(event)``) like the monitor's others, which also
takes a commit's events as one group (``emit_many(events)``: one twin transaction for the group)."""

from __future__ import annotations

from collections.abc import Sequence

from bim2rdt.bus.event import Event


class TwinSink:
    """Appends every safety event the monitor emits to the twin (``DigitalTwin.record_events``)."""

    def __init__(self, twin):
        self.twin = twin

    def emit(self, event: Event) -> None:
        self.twin.record_event(event)

    def emit_many(self, events: Sequence[Event]) -> None:
        """The events of one monitor commit, in one transaction (all recorded, or none on an error)."""
        self.twin.record_events(events)
