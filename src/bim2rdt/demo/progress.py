"""The day's progress against the site's work schedule (``progress.json``, ``progress_curve.json``, the tasks'
progress written into ``site_twin.ifc``) and its report section: the task table by status, the S-curve and the
structure in 3-D by built / not built.

The structure's judgements come from ``structure.json`` in the day's folder when the day wrote one (or are given);
the site objects' verdicts come from the twin.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from bim2rdt.atomic import write_bytes_atomic
from bim2rdt.perception.structure import permanent_elements
from bim2rdt.twin.progress import merge_statuses
from bim2rdt.twin.progress_config import ProgressConfig
from bim2rdt.twin.progress_files import (ProgressFiles, curve_dict, read_structure_statuses, write_progress)
from bim2rdt.twin.progress_history import observation_times, twin_statuses
from bim2rdt.twin.progress_report import progress_markdown, progress_section_html, structure_png

STRUCTURE_PNG = "progress_structure.png"


def write_day_progress(day, out_dir: Path, config: ProgressConfig = ProgressConfig(),
                       structure: Mapping[str, str] | None = None) -> ProgressFiles | None:
    """Write the day's progress files and the structure view (``progress_structure.png``) when the site has a work
    schedule.

    Args:
        day: The ``SiteDay`` (its twin open, its exports written).
        out_dir: The day's folder.
        config: When a task is behind or ahead.
        structure: {GlobalId: structure status}; None reads ``out_dir/structure.json`` (none when absent).

    Returns:
        The files written, or None without a schedule.
    """
    structure = read_structure_statuses(out_dir / "structure.json") if structure is None else dict(structure)
    seen = observation_times(day.twin)
    ifc = day.twin_files.ifc if day.twin_files is not None else None
    files = write_progress(day.twin, out_dir, twin_ifc=ifc, structure=structure,
                           structure_time=seen[0] if seen else None, behind_percent=config.behind_percent,
                           ahead_percent=config.ahead_percent)
    if files is not None:
        states = merge_statuses(twin_statuses(day.twin.state()), structure)
        meshes = {el.global_id: day.model.mesh(el.global_id) for el in permanent_elements(day.model)}
        write_bytes_atomic(out_dir / STRUCTURE_PNG, structure_png(meshes, states))
    return files


def progress_html(files: ProgressFiles) -> str:
    """The report's progress section (body only), with the structure view written beside progress.json.

    Args:
        files: What :func:`write_day_progress` wrote.

    Returns:
        HTML, images embedded.
    """
    picture = files.progress_json.parent / STRUCTURE_PNG
    return progress_section_html(files.progress.to_dict(), curve_dict(files.curve),
                                 picture.read_bytes() if picture.exists() else None, heading=False)


def progress_text(files: ProgressFiles) -> str:
    """The report.md section: the task table.

    Args:
        files: What :func:`write_day_progress` wrote.

    Returns:
        Markdown.
    """
    record = files.progress.to_dict()
    return (f"\n## Progress against the schedule ({record['schedule']['name']}, {record['date']})\n\n"
            + progress_markdown(record))

