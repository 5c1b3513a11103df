"""The day's progress against the site's work schedule (``progress.json``, ``progress_curve.json``,
``progress_structure.png``, the tasks' progress written into ``site_twin.ifc``) and its report sections: the task
table by status, the S-curve and the structure by built / not built.

The structure's judgements come from ``structure.json`` in the day's folder when the day wrote one (or are given);
the site objects' verdicts come from the twin.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from bim2rdt.twin import (ProgressConfig, ProgressFiles, progress_markdown, progress_section, read_structure_statuses,
                          write_progress)


def write_day_progress(day, out_dir: Path, config: ProgressConfig = ProgressConfig(),
                       structure: Mapping[str, str] | None = None) -> ProgressFiles | None:
    """Write the day's progress files when the site has a work schedule.

    Args:
        day: The ``SiteDay`` (its twin open, its exports written).
        out_dir: The day's folder.
        config: When a task is behind or ahead.
        structure: {GlobalId: structure status}; None reads ``out_dir/structure.json`` (none when absent).

    Returns:
        The files written, or None without a schedule.
    """
    structure = read_structure_statuses(out_dir / "structure.json") if structure is None else dict(structure)
    ifc = day.twin_files.ifc if day.twin_files is not None else None
    return write_progress(day.twin, out_dir, twin_ifc=ifc, structure=structure, behind_percent=config.behind_percent,
                          ahead_percent=config.ahead_percent)


def progress_html(files: ProgressFiles) -> str:
    """The report's progress section (body only).

    Args:
        files: What :func:`write_day_progress` wrote.

    Returns:
        HTML, images embedded.
    """
    return progress_section(files.progress_json.parent, heading=False) or ""


def progress_text(files: ProgressFiles) -> str:
    """The report.md section: the task table.

    Args:
        files: What :func:`write_day_progress` wrote.

    Returns:
        Markdown.
    """
    record = files.progress.to_dict()
    return (f"\n## Progress against the schedule ({record['schedule']['name']}, {record['date']})\n\n"
            + progress_markdown(record) + "\n![structure: built / not built](progress_structure.png)\n")
