"""The progress of a run, from its twin: ``progress.json`` (the contract other tools read), ``progress_curve.json``
(the S-curve, planned against observed) and the write-back into the twin's IFC. ``verify`` and ``demo`` call
:func:`write_progress` after exporting the twin; a model without a work schedule writes nothing.

The structure's judgements reach progress as ``structure.json`` (a list of ``{"global_id", "status", ...}``), read
by :func:`read_structure_statuses`.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING

import ifcopenshell

from bim2rdt.atomic import write_bytes_atomic
from bim2rdt.bim import WorkSchedule, product_quantities, read_work_schedules
from bim2rdt.bim import read_source
from bim2rdt.perception import permanent_elements
from bim2rdt.twin.errors import TwinError
from bim2rdt.twin.progress import BUILT, PartlyBuilt, ScheduleProgress, merge_statuses
from bim2rdt.twin.progress_groups import GroupProgress, group_progress
from bim2rdt.twin.progress_history import (CurvePoint, curve_dates, observation_times, progress_over_time,
                                           twin_statuses, twin_statuses_at)
from bim2rdt.twin.progress_ifc import write_progress_ifc
from bim2rdt.twin.progress_report import BUILT_COLOURS, TASK_COLOURS, progress_section_html, structure_png

PROGRESS_JSON, CURVE_JSON, STRUCTURE_PNG = "progress.json", "progress_curve.json", "progress_structure.png"
EARLIEST_CLOCK = datetime(2000, 1, 1, tzinfo=timezone.utc)
"""Observation times under this are frame indices, not a clock (a recording without stamps)."""

if TYPE_CHECKING:
    from bim2rdt.twin.twin import DigitalTwin


@dataclass
class ProgressFiles:
    """What :func:`write_progress` wrote: ``progress.json``, ``progress_curve.json``, ``progress_structure.png``
    (the structure on plan, built / not built), the twin IFC it wrote the tasks' progress into (None when there
    was none, with ``ifc_note`` saying why), and the progress itself."""

    progress_json: Path
    curve_json: Path
    structure_png: Path
    progress: ScheduleProgress
    curve: list[CurvePoint]
    ifc: Path | None = None
    ifc_note: str | None = None


def read_structure_statuses(path: str | Path) -> dict[str, str]:
    """``structure.json``'s judgements as {GlobalId: status}; empty when the file does not exist. A built element
    with a ``built_share`` under 1 (partly built) is a :class:`~bim2rdt.twin.progress.PartlyBuilt` status.

    Args:
        path: The structure.json file (a list of objects with ``global_id`` and ``status``).

    Returns:
        {GlobalId: "as planned" | "deviating" | "not built" | "not observed"}.

    Raises:
        TwinError: The file is not such a list.
    """
    path = Path(path)
    if not path.is_file():
        return {}
    try:
        rows = json.loads(path.read_text(encoding="utf-8"))
        return {str(row["global_id"]): _state(row) for row in rows}
    except (ValueError, TypeError, KeyError) as error:
        raise TwinError(f"{path.name}: not a list of structure judgements ({error})") from None


def _state(row: dict) -> str:
    """One judgement's status; a :class:`PartlyBuilt` where it is built on only part of its face."""
    status, share = str(row["status"]), row.get("built_share")
    if share is not None and status in BUILT and float(share) < 1.0:
        return PartlyBuilt(status, float(share))
    return status


def twin_progress(twin: DigitalTwin, schedule: WorkSchedule, *, ifc: ifcopenshell.file | None = None,
                  at: datetime | None = None,
                  structure: Mapping[str, str] | None = None, structure_time: datetime | None = None,
                  behind_percent: float = 10.0, ahead_percent: float = 10.0) -> tuple[ScheduleProgress,
                                                                                     list[CurvePoint]]:
    """A schedule's progress from a twin at ``at`` (default: the twin's last observation, else now), with actual
    starts and finishes and the S-curve from its history.

    Args:
        twin: A ``DigitalTwin`` of the schedule's model.
        schedule: The work schedule.
        ifc: The model's open IFC file (for its IfcElementQuantity); None opens ``twin.model.path``.
        at: The progress date (aware); None: the twin's last observation time, else now.
        structure: {GlobalId: structure status} merged over the twin's verdicts.
        structure_time: When the structure was judged; None: always.
        behind_percent: Percentage points under planned beyond which a task is behind.
        ahead_percent: Percentage points over planned beyond which a task is ahead.

    Returns:
        (progress, S-curve points).
    """
    observed = [t for t in observation_times(twin) if t >= EARLIEST_CLOCK]
    now = at or (observed[-1] if observed else datetime.now(timezone.utc))
    products = [p for task in schedule.tasks for p in task.products]
    ifc = ifc if ifc is not None else read_source(Path(twin.model.path)).ifc
    quantities = product_quantities(twin.model, ifc, products)
    dates = curve_dates(schedule, [t for t in observed if t <= now], now)
    statuses_at = twin_statuses_at(twin, structure, structure_time)
    return progress_over_time(schedule, quantities, statuses_at, now, dates, behind_percent, ahead_percent)


def progress_of(twin: DigitalTwin, *, ifc: ifcopenshell.file | None = None, at: datetime | None = None,
                structure: Mapping[str, str] | None = None,
                behind_percent: float = 10.0, ahead_percent: float = 10.0
                ) -> tuple[ScheduleProgress | None, list[CurvePoint], list[GroupProgress]]:
    """A twin's progress at ``at``: against its model's first work schedule (with its S-curve), else by storey
    and by class.

    Args:
        twin: A ``DigitalTwin``.
        ifc: The model's open IFC file; None opens ``twin.model.path``.
        at: The date (aware); None: the twin's last observation, else now.
        structure: {GlobalId: structure status} merged over the twin's verdicts.
        behind_percent: Percentage points under planned beyond which a task is behind.
        ahead_percent: Percentage points over planned beyond which a task is ahead.

    Returns:
        (the schedule's progress, its S-curve, []) when the model has a schedule; (None, [], groups by storey
            then class) when not.
    """
    ifc = ifc if ifc is not None else read_source(Path(twin.model.path)).ifc
    schedules = read_work_schedules(ifc)
    if schedules:
        progress, curve = twin_progress(twin, schedules[0], ifc=ifc, at=at, structure=structure,
                                        behind_percent=behind_percent, ahead_percent=ahead_percent)
        return progress, curve, []
    states = twin_statuses_at(twin, structure)(at or datetime.now(timezone.utc))
    ids = [el.global_id for el in permanent_elements(twin.model)]
    return None, [], group_progress(twin.model, states, product_quantities(twin.model, ifc, ids))


def write_progress(twin: DigitalTwin, out_dir: Path, *, twin_ifc: Path | None = None,
                   structure: Mapping[str, str] | None = None,
                   structure_time: datetime | None = None, behind_percent: float = 10.0,
                   ahead_percent: float = 10.0) -> ProgressFiles | None:
    """Write ``progress.json``, ``progress_curve.json`` and ``progress_structure.png`` into ``out_dir`` and the
    tasks' progress into ``twin_ifc``, when the twin's model has a work schedule.

    Args:
        twin: The run's ``DigitalTwin``.
        out_dir: The run's folder.
        twin_ifc: The exported twin IFC to write the progress into; None writes no IFC.
        structure: {GlobalId: structure status} (see :func:`read_structure_statuses`).
        structure_time: When the structure was judged; None: the twin's first observation (the run's start).
        behind_percent: Percentage points under planned beyond which a task is behind.
        ahead_percent: Percentage points over planned beyond which a task is ahead.

    Returns:
        The files and the progress; None when the model has no work schedule.
    """
    ifc = read_source(Path(twin.model.path)).ifc
    schedules = read_work_schedules(ifc)
    if not schedules:
        return None
    if structure_time is None:
        seen = observation_times(twin)
        structure_time = seen[0] if seen else None
    progress, curve = twin_progress(twin, schedules[0], ifc=ifc, structure=structure,
                                    structure_time=structure_time, behind_percent=behind_percent,
                                    ahead_percent=ahead_percent)
    states = merge_statuses(twin_statuses(twin.state()), structure or {})
    meshes = {el.global_id: twin.model.mesh(el.global_id) for el in permanent_elements(twin.model)}
    files = ProgressFiles(
        write_bytes_atomic(out_dir / PROGRESS_JSON, json.dumps(progress.to_dict(), indent=1).encode("utf-8")),
        write_bytes_atomic(out_dir / CURVE_JSON, json.dumps(curve_dict(curve), indent=1).encode("utf-8")),
        write_bytes_atomic(out_dir / STRUCTURE_PNG, structure_png(meshes, states)), progress, curve)
    if twin_ifc is not None:
        try:
            files.ifc = write_progress_ifc(twin_ifc, progress)
        except TwinError as error:
            files.ifc_note = str(error)
    return files


def curve_dict(curve: list[CurvePoint]) -> dict:
    """The S-curve as progress_curve.json writes it.

    Args:
        curve: The curve's points.

    Returns:
        {"points": [{"date": ISO 8601, "planned_percent", "observed_percent"}]}.
    """
    def rounded(value):
        return round(value, 1) if value is not None else None

    return {"points": [{"date": p.date.isoformat(), "planned_percent": rounded(p.planned_percent),
                        "observed_percent": rounded(p.observed_percent)} for p in curve]}


def progress_section(out_dir: str | Path, heading: bool = True) -> str | None:
    """The report's progress section from the files :func:`write_progress` left in a run's folder (for the verify
    report and the demo's).

    Args:
        out_dir: The run's folder.
        heading: Wrap it in a ``<section>`` with its own ``<h2>``; False gives the body only.

    Returns:
        HTML with the images embedded, or None when the folder has no progress.json (no schedule).
    """
    out_dir = Path(out_dir)
    if not (out_dir / PROGRESS_JSON).is_file():
        return None
    progress = json.loads((out_dir / PROGRESS_JSON).read_text(encoding="utf-8"))
    curve = json.loads((out_dir / CURVE_JSON).read_text(encoding="utf-8")) if (out_dir / CURVE_JSON).is_file() \
        else None
    picture = (out_dir / STRUCTURE_PNG).read_bytes() if (out_dir / STRUCTURE_PNG).is_file() else None
    return progress_section_html(progress, curve, picture, heading=heading)


def progress_record(twin: DigitalTwin, ifc: ifcopenshell.file | None = None, at: float | None = None,
                    behind_percent: float = 10.0,
                    ahead_percent: float = 10.0) -> dict:
    """The progress as the dashboard draws it, with the structure's judgements of ``structure.json`` beside the
    model's IFC file (where verify and the demo write them) when there is one.

    Args:
        twin: A ``DigitalTwin``.
        ifc: The model's open IFC file (a server keeps it); None opens ``twin.model.path``.
        at: A past time, UTC seconds; None: the twin's last observation.
        behind_percent: Percentage points under planned beyond which a task is behind.
        ahead_percent: Percentage points over planned beyond which a task is ahead.

    Returns:
        {"progress": progress.json's document or None (no schedule), "curve": the S-curve's points, "groups": by
            storey and class (no schedule), "structure": {GlobalId: state} of the permanent elements, "colours":
            {task status: colour}, "state_colours": {built | not built | not observed: colour}}.
    """
    structure = read_structure_statuses(Path(twin.model.path).parent / "structure.json")
    when = datetime.fromtimestamp(at, timezone.utc) if at is not None else None
    progress, curve, groups = progress_of(twin, ifc=ifc, at=when, structure=structure,
                                          behind_percent=behind_percent, ahead_percent=ahead_percent)
    states = merge_statuses(twin_statuses(twin.state(at)), structure)
    permanent = sorted(el.global_id for el in permanent_elements(twin.model))
    return {"progress": progress.to_dict() if progress is not None else None, "curve": curve_dict(curve)["points"],
            "groups": [g.to_dict() for g in groups],
            "structure": {gid: states.get(gid, "not observed") for gid in permanent},
            "colours": TASK_COLOURS, "state_colours": BUILT_COLOURS}


def open_model_ifc(twin: DigitalTwin) -> ifcopenshell.file:
    """The twin's model as an open IFC file (for :func:`progress_record`, which a server calls often).

    Args:
        twin: A ``DigitalTwin``.

    Returns:
        The ifcopenshell file.

    Raises:
        BimError: The file cannot be read.
    """
    return read_source(Path(twin.model.path)).ifc
