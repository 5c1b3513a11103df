"""Progress written back into the twin's IFC: each task of the schedule gets its IfcTaskTime ActualStart,
ActualFinish, Completion and StatusTime, and its IfcTask.Status (the progress status: "behind", "complete", ...).

Completion is IfcPositiveRatioMeasure (0 < ratio): a task with nothing built leaves it unset. A later read of the
written file takes Completion as the task's planned percentage (``bim.schedule``'s reader does): the file then
says what was done, which is what a planner's tool shows.
"""

from __future__ import annotations

from datetime import datetime, timezone
from pathlib import Path

import ifcopenshell
import ifcopenshell.api.sequence
import ifcopenshell.util.date

from bim2rdt.atomic import write_bytes_atomic
from bim2rdt.twin.errors import TwinError
from bim2rdt.twin.progress import ScheduleProgress, TaskProgress


def write_progress_ifc(path: str | Path, progress: ScheduleProgress, out: str | Path | None = None) -> Path:
    """Write ``progress`` into the tasks of an IFC4 file (the twin's, as ``export_ifc`` wrote it).

    Args:
        path: The IFC file holding the schedule's tasks.
        progress: The schedule's progress (with actual starts and finishes where known).
        out: Where to write (atomically); None overwrites ``path``.

    Returns:
        The written path.

    Raises:
        TwinError: The file is IFC2X3 or lacks a task of the schedule.
    """
    ifc = ifcopenshell.open(str(path))
    if ifc.schema == "IFC2X3":
        raise TwinError(f"{Path(path).name}: IFC2X3 has no IfcTaskTime to write progress into")
    for row in progress.tasks:
        try:
            task = ifc.by_guid(row.task.global_id)
        except RuntimeError:
            raise TwinError(f"{Path(path).name}: no task {row.task.global_id} of schedule "
                            f"{progress.schedule.name!r}") from None
        _write_task(ifc, task, row, progress)
    target = Path(out) if out is not None else Path(path)
    return write_bytes_atomic(target, ifc.to_string().encode("utf-8"))


def _write_task(ifc: ifcopenshell.file, task: ifcopenshell.entity_instance, row: TaskProgress,
                progress: ScheduleProgress) -> None:
    task_time = task.TaskTime or ifcopenshell.api.sequence.add_task_time(ifc, task=task)
    task_time.StatusTime = _ifc_datetime(progress.date)
    task_time.ActualStart = _ifc_datetime(row.actual_start) if row.actual_start is not None else None
    task_time.ActualFinish = _ifc_datetime(row.actual_finish) if row.actual_finish is not None else None
    observed = row.observed_percent
    task_time.Completion = min(observed, 100.0) / 100.0 if observed is not None and observed > 0.0 else None
    ifcopenshell.api.sequence.edit_task(ifc, task=task, attributes={"Status": row.status.value})


def _ifc_datetime(value: datetime) -> str:
    """IfcDateTime in UTC without an offset (the reader takes an offset-less time as UTC)."""
    return ifcopenshell.util.date.datetime2ifc(value.astimezone(timezone.utc).replace(tzinfo=None), "IfcDateTime")
