"""HAV events into the twin's IFC: IfcEvent for activity start/end and limit crossings, IfcTask for the
intervention and for the sensed activity itself (the paper's "Safety-Aware Digital Twin Updates").

* activity started -> IfcEvent STARTEVENT;  activity ended -> IfcEvent ENDEVENT with the day's A(8), and an
  IfcTask spanning the activity (an *activity instance*, measured ActualStart/ActualFinish);
* EAV reached -> IfcEvent + IfcTask "safety instructor intervention" sequenced after it; ELV reached ->
  IfcEvent + IfcTask "stop vibrating work" sequenced after it.

Every record carries the ``BIM2RDT_Event`` / ``BIM2RDT_Task`` property set: a_hv, A(8), HSE points, limit, risk
flag, pseudonym (never a name), tool, estimate/band flags. Records are linked to the worker's work zone (the
session's zone: a zone name or any product GlobalId). Where the IFC has a work schedule, the activity reuses
its vocabulary: the scheduled IfcTask operating on that zone/product (or whose name mentions the tool's work)
lends its name, and the activity task is nested under it; without one, the records stand on their own.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from bim2rdt.bim import BimModel, BimProcess
from bim2rdt.bus import Event
from bim2rdt.safety.activity import ACTIVITY_ENDED, ACTIVITY_STARTED, EAV_REACHED, ELV_REACHED

if TYPE_CHECKING:
    from bim2rdt.bim import TwinWriter

TOOL_WORDS = {"hammer_drill": ("drill", "anchor", "core"), "grinder": ("grind", "cut", "chase"),
              "breaker": ("break", "demoli", "chisel")}
"""Words a scheduled task's name may use for the work a tool does."""
TOOL_LABELS = {"hammer_drill": "hammer drilling", "grinder": "grinding", "breaker": "breaking"}


class IfcSink:
    """Writes HAV events through a :class:`bim2rdt.bim.TwinWriter` (call ``writer.save`` to persist); ``records``
    lists (IFC class, GlobalId) of everything written, in order.

    Args:
        writer: The writer of the twin's IFC that takes the IfcEvent and IfcTask records.
        model: The BIM model whose zones, products and scheduled tasks the records are linked to.
    """

    def __init__(self, writer: TwinWriter, model: BimModel):
        self.writer, self.model = writer, model
        self._zones = {z.name: z.global_id for z in model.zones} | {z.global_id: z.global_id for z in model.zones}
        self._products = {el.global_id for el in model.elements}
        self._started: dict[str, tuple[str, float]] = {}
        self.records: list[tuple[str, str]] = []
        """(IFC class, GlobalId) of everything written, in order."""
        self._handlers: dict[str, Callable[[Event], None]] = {
            ACTIVITY_STARTED: self._activity_started, ACTIVITY_ENDED: self._activity_ended,
            EAV_REACHED: self._limit_reached, ELV_REACHED: self._limit_reached}

    def emit(self, event: Event) -> None:
        """Write the IFC records of one HAV event: activity started or ended, EAV or ELV reached; other kinds
        write nothing.

        Args:
            event: A bus event from the HAV monitor.
        """
        handler = self._handlers.get(event.kind)
        if handler is not None:
            handler(event)

    def _activity_started(self, event: Event) -> None:
        gid = self.writer.add_event(f"HAV activity started: {_tool_label(event)}", event.time, "start",
                                    self._related(event), _properties(event))
        self._started[event.data["activity"]] = (gid, event.time)
        self.records.append(("IfcEvent", gid))

    def _limit_reached(self, event: Event) -> None:
        eav = event.kind == EAV_REACHED
        name = "exposure action value (EAV)" if eav else "exposure limit value (ELV)"
        related, props = self._related(event), _properties(event)
        gid = self.writer.add_event(f"HAV {name} reached", event.time, "intermediate", related, props)
        task_name = ("Safety instructor intervention: reduce vibration exposure" if eav
                     else "Stop vibrating work for the day: exposure limit reached")
        task = self.writer.add_task(task_name, event.time, None, related, {**props, "Assignee": "safety instructor"},
                                    after=gid)
        self.records += [("IfcEvent", gid), ("IfcTask", task)]

    def _activity_ended(self, event: Event) -> None:
        related, props = self._related(event), _properties(event)
        end = self.writer.add_event(f"HAV activity ended: {_tool_label(event)}", event.time, "end", related, props)
        start_gid, started = self._started.pop(event.data["activity"], (None, event.data.get("started")))
        planned = self._scheduled_task(event)
        name = f"{planned.name}: {_tool_label(event)} (sensed)" if planned else f"{_tool_label(event)} (sensed)"
        task_props = {**props, "ScheduleTask": planned.global_id if planned else None}
        task = self.writer.add_task(name, started if started is not None else event.time, event.time, related,
                                    task_props, after=start_gid)
        self.writer.add_sequence(task, end)
        if planned is not None:
            _nest(self.writer, planned.global_id, task)
        self.records += [("IfcEvent", end), ("IfcTask", task)]

    def _related(self, event: Event) -> list[str]:
        """The worker's zone as a product GlobalId (a zone name is resolved; unknown ones are left out)."""
        zone = event.data.get("zone")
        if zone in self._zones:
            return [self._zones[zone]]
        return [zone] if zone in self._products else []

    def _scheduled_task(self, event: Event) -> BimProcess | None:
        related = set(self._related(event))
        for task in self.model.tasks:
            if related & set(task.related):
                return task
        words = TOOL_WORDS.get(event.data.get("tool", ""), ())
        return next((t for t in self.model.tasks if any(w in (t.name or "").lower() for w in words)), None)


def _tool_label(event: Event) -> str:
    tool = event.data.get("tool", "unknown")
    return TOOL_LABELS.get(tool, tool.replace("_", " "))


def _properties(event: Event) -> dict:
    """The pset of a HAV record: exposure figures in m/s^2 and points, flags, the pseudonym."""
    data = event.data
    limit = data.get("limit")
    return {"Pseudonym": event.subject, "Activity": data.get("activity"), "Tool": data.get("tool"),
            "Device": event.source, "AHv": data.get("a_hv"), "DailyExposureA8": data.get("day_a8"),
            "ExposurePoints": data.get("day_points"), "Limit": {2.5: "EAV", 5.0: "ELV"}.get(limit),
            "LimitValue": limit, "RiskFlag": data.get("risk"), "Estimate": data.get("estimate"),
            "BandLimited": data.get("band_limited"), "TriggerTime": data.get("trigger_s")}


def _nest(writer, parent: str, child: str) -> None:
    """Nest the sensed activity task under the scheduled one (IfcRelNests: an instance of planned work)."""
    import ifcopenshell.api.nest

    ifcopenshell.api.nest.assign_object(writer.ifc, related_objects=[writer.ifc.by_guid(child)],
                                        relating_object=writer.ifc.by_guid(parent))
