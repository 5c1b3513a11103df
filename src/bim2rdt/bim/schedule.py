"""Reading a 4-D schedule: ``IfcWorkSchedule``, its nested ``IfcTask`` tree, each task's ``IfcTaskTime``, the
products each task builds (``IfcRelAssignsToProduct``, the task's outputs) and its predecessors
(``IfcRelSequence``).

The walk is IfcOpenShell's own (``ifcopenshell.util.sequence``: root tasks, nested tasks, outputs, sequence
assignments), so a schedule Bonsai or any planner writes reads the same here as there. IFC2X3 has no
IfcTaskTime; a 2X3 file reads as having no schedule (progress then falls back to storeys and classes).
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

import ifcopenshell
import ifcopenshell.util.sequence

from bim2rdt.bim.processes import parse_ifc_datetime
from bim2rdt.bim.source import read_source


@dataclass(frozen=True)
class ScheduledTask:
    """One ``IfcTask`` of a work schedule. Times are timezone-aware UTC (None where the file leaves them unset);
    ``completion`` is IfcTaskTime.Completion as a fraction (0-1, None where unset); ``products`` are the GlobalIds
    of the products the task itself builds (its outputs), ``children`` the GlobalIds of its nested tasks in the
    file's order, ``predecessors`` those of the tasks it follows through IfcRelSequence."""

    global_id: str
    name: str | None
    identification: str | None
    schedule_start: datetime | None
    schedule_finish: datetime | None
    completion: float | None = None
    products: tuple[str, ...] = ()
    children: tuple[str, ...] = ()
    parent: str | None = None
    predecessors: tuple[str, ...] = ()

    @property
    def is_summary(self) -> bool:
        """True for a task with nested tasks (its progress rolls up theirs)."""
        return bool(self.children)


@dataclass(frozen=True)
class WorkSchedule:
    """An ``IfcWorkSchedule`` and its tasks, depth first (each root task, then its nested tasks)."""

    global_id: str
    name: str | None
    tasks: tuple[ScheduledTask, ...]

    def task(self, global_id: str) -> ScheduledTask:
        """The task with this GlobalId.

        Args:
            global_id: The IfcTask's GlobalId.

        Returns:
            The task.

        Raises:
            KeyError: The schedule has no such task.
        """
        for task in self.tasks:
            if task.global_id == global_id:
                return task
        raise KeyError(f"the schedule has no task {global_id}")

    @property
    def roots(self) -> tuple[ScheduledTask, ...]:
        """The tasks nested in no other task."""
        return tuple(task for task in self.tasks if task.parent is None)


def read_work_schedules(ifc: ifcopenshell.file) -> list[WorkSchedule]:
    """Every IfcWorkSchedule of an open file with at least one task, in file order (none for IFC2X3).

    Args:
        ifc: An open IFC file.

    Returns:
        The schedules, each with its task tree.
    """
    if ifc.schema == "IFC2X3":
        return []
    schedules = []
    for schedule in ifc.by_type("IfcWorkSchedule"):
        tasks = tuple(_task(task) for task in ifcopenshell.util.sequence.get_work_schedule_tasks(schedule))
        if tasks:
            schedules.append(WorkSchedule(schedule.GlobalId, schedule.Name, tasks))
    return schedules


def read_work_schedule(path: str | Path) -> WorkSchedule | None:
    """The first work schedule with tasks of an IFC file, or None when it has none.

    Args:
        path: The .ifc file.

    Returns:
        The schedule, or None.

    Raises:
        BimError: The file cannot be read (one line naming it).
    """
    schedules = read_work_schedules(read_source(Path(path)).ifc)
    return schedules[0] if schedules else None


def _task(task: ifcopenshell.entity_instance) -> ScheduledTask:
    time = task.TaskTime
    parent = ifcopenshell.util.sequence.get_parent_task(task)
    outputs = sorted(ifcopenshell.util.sequence.get_task_outputs(task), key=lambda product: product.id())
    predecessors = [rel.RelatingProcess.GlobalId
                    for rel in ifcopenshell.util.sequence.get_sequence_assignment(task, "predecessor")]
    return ScheduledTask(
        task.GlobalId, task.Name, task.Identification,
        parse_ifc_datetime(time.ScheduleStart) if time is not None else None,
        parse_ifc_datetime(time.ScheduleFinish) if time is not None else None,
        float(time.Completion) if time is not None and time.Completion is not None else None,
        tuple(product.GlobalId for product in outputs),
        tuple(child.GlobalId for child in ifcopenshell.util.sequence.get_nested_tasks(task)),
        parent.GlobalId if parent is not None else None, tuple(predecessors))
