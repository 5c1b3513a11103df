"""Reading 4D/safety processes back: ``IfcEvent`` and ``IfcTask`` with their times, links and sequences.

This is the reader the writer (``TwinWriter``) is checked against. IFC2X3 has tasks but no events and no
IfcTaskTime; there this returns what exists with times left None.
"""

from __future__ import annotations

from datetime import datetime, timezone

import ifcopenshell

from bim2rdt.bim.psets import read_psets
from bim2rdt.bim.records import BimProcess


def read_events(ifc: ifcopenshell.file) -> list[BimProcess]:
    """Every IfcEvent with its occurrence time (IfcEventTime.ActualDate, else ScheduleDate)."""
    if ifc.schema == "IFC2X3":
        return []
    events = []
    for event in ifc.by_type("IfcEvent"):
        time = event.EventOccurenceTime
        when = parse_ifc_datetime(time.ActualDate or time.ScheduleDate) if time is not None else None
        events.append(BimProcess(event.GlobalId, "IfcEvent", event.Name, event.PredefinedType, when, None,
                                 event.EventTriggerType, _related(event), _after(event), read_psets(event)))
    return events


def read_tasks(ifc: ifcopenshell.file) -> list[BimProcess]:
    """Every IfcTask with actual start/finish, falling back to scheduled, then early times (planners' files)."""
    tasks = []
    for task in ifc.by_type("IfcTask"):
        time = getattr(task, "TaskTime", None)
        start = finish = None
        if time is not None:
            start = parse_ifc_datetime(time.ActualStart or time.ScheduleStart or time.EarlyStart)
            finish = parse_ifc_datetime(time.ActualFinish or time.ScheduleFinish or time.EarlyFinish)
        tasks.append(BimProcess(task.GlobalId, "IfcTask", task.Name, getattr(task, "PredefinedType", None),
                                start, finish, None, _related(task), _after(task), read_psets(task)))
    return tasks


def parse_ifc_datetime(text: str | None) -> datetime | None:
    """IfcDateTime (ISO 8601) -> aware datetime; a time without offset is taken as UTC."""
    if not text:
        return None
    value = datetime.fromisoformat(text.replace("Z", "+00:00"))
    return value if value.tzinfo is not None else value.replace(tzinfo=timezone.utc)


def _related(process: ifcopenshell.entity_instance) -> tuple[str, ...]:
    """Products the process is assigned to (IfcRelAssignsToProduct) or that are assigned to it (...ToProcess)."""
    ids = [rel.RelatingProduct.GlobalId for rel in process.HasAssignments or []
           if rel.is_a("IfcRelAssignsToProduct")]
    ids += [obj.GlobalId for rel in getattr(process, "OperatesOn", None) or [] for obj in rel.RelatedObjects]
    return tuple(dict.fromkeys(ids))


def _after(process: ifcopenshell.entity_instance) -> tuple[str, ...]:
    return tuple(rel.RelatingProcess.GlobalId for rel in getattr(process, "IsSuccessorFrom", None) or [])
