"""The HAV monitor's events into the twin's history: a sink (``emit(event)``) like the monitor's others."""

from __future__ import annotations

from bim2rdt.bus.event import Event


class TwinSink:
    """Appends every safety event the monitor emits to the twin (``DigitalTwin.record_event``)."""

    def __init__(self, twin):
        self.twin = twin

    def emit(self, event: Event) -> None:
        self.twin.record_event(event)
