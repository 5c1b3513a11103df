"""What ``verify`` writes into its folder: the twin (``twin.db``, exported as ``twin.json``, ``twin.ifc`` and
``issues.bcf`` by the twin's own exporters), ``localization.json`` and ``report.html``."""

from __future__ import annotations

import html
import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from bim2rdt.atomic import write_bytes_atomic
from bim2rdt.bim import BimModel
from bim2rdt.twin import (DigitalTwin, ElementState, ElementStatus, ProgressConfig, TwinConfig, TwinError,
                          read_structure_statuses, write_progress)
from bim2rdt.verify.chain import VerifyResult, family_priors

TWIN_DB = "twin.db"


@dataclass
class VerifyFiles:
    """The files written (``ifc`` None with ``ifc_note`` when the model cannot be written back)."""

    twin_json: Path
    bcf: Path
    localization: Path
    report: Path
    ifc: Path | None
    ifc_note: str | None = None
    progress: Path | None = None
    """progress.json, when the model has a work schedule."""


def record_twin(result: VerifyResult, model: BimModel, out_dir: Path, config: TwinConfig = TwinConfig(),
                robot: str = "verify", symmetry: Mapping[str, float] | None = None) -> DigitalTwin:
    """A fresh twin at ``out_dir/twin.db`` with every frame's observations and the places it saw empty (time: the
    frame's, else its index; camera: the fixed pose).

    Args:
        result: What verify found in every frame.
        model: The BIM the twin is of.
        out_dir: The verify folder; a twin.db already there is replaced.
        config: The twin's tolerances and ``min_fitness``.
        robot: The records' source.
        symmetry: Each family's rotational order about up (default: its upright prior's,
            :func:`~bim2rdt.verify.chain.family_priors`), as the demo's twin has them.

    Returns:
        The open twin (the caller closes it).
    """
    for stale in (TWIN_DB, f"{TWIN_DB}-wal", f"{TWIN_DB}-shm"):
        (out_dir / stale).unlink(missing_ok=True)
    if symmetry is None:
        symmetry = {family: prior.symmetry for family, prior in family_priors(model).items()}
    twin = DigitalTwin.open(f"sqlite:///{out_dir / TWIN_DB}", model, tolerances=config.tolerance_policy(),
                            symmetry=dict(symmetry), min_fitness=config.min_fitness, robot=robot)
    for frame in result.frames:
        when = frame.time if frame.time is not None else float(frame.index)
        for observation in frame.observations:
            twin.record(observation, when, camera=frame.pose)
        for global_id in frame.missing:
            twin.mark_missing(global_id, when, frames=(frame.index,), camera=frame.pose)
    return twin


def write_outputs(result: VerifyResult, twin: DigitalTwin, out_dir: Path,
                  progress: ProgressConfig = ProgressConfig()) -> VerifyFiles:
    """Write every file of the verify folder; with a work schedule in the model also progress.json (and its
    curve and structure view), with ``structure.json``'s judgements where the folder has one.

    Args:
        result: What verify found in every frame.
        twin: The twin :func:`record_twin` made of it.
        out_dir: The verify folder.
        progress: When a task of the schedule is behind or ahead.

    Returns:
        The paths of twin.json, issues.bcf, localization.json, report.html and twin.ifc (None, with a note,
            when the model cannot be written back).
    """
    localization = write_bytes_atomic(out_dir / "localization.json", json.dumps(
        {"frames": [f.to_dict() for f in result.frames], "miscalibrated": result.miscalibrated,
         "warnings": result.warnings + result.source_warnings, "dropped": result.dropped,
         "dropped_counts": result.drop_counts}, indent=1).encode())
    files = VerifyFiles(twin.export_json(out_dir / "twin.json"), twin.export_bcf(out_dir / "issues.bcf"), localization,
                        out_dir / "report.html", None)
    try:
        files.ifc = twin.export_ifc(out_dir / "twin.ifc")
    except TwinError as error:
        files.ifc_note = str(error)
    written = write_progress(twin, out_dir, twin_ifc=files.ifc,
                             structure=read_structure_statuses(out_dir / "structure.json"),
                             behind_percent=progress.behind_percent, ahead_percent=progress.ahead_percent)
    files.progress = written.progress_json if written is not None else None
    write_bytes_atomic(files.report, report_html(result, twin.state()).encode())
    return files


def verdict_counts(states: dict[str, ElementState]) -> dict[str, int]:
    counts = {s.value: 0 for s in ElementStatus}
    for state in states.values():
        counts[state.status.value] += 1
    return counts


def report_html(result: VerifyResult, states: dict[str, ElementState]) -> str:
    """A one-page report: warnings, each frame's fix and each observed element's verdict."""
    rows = "".join(
        f"<tr><td>{f.index}</td><td>{html.escape(f.source)}</td><td>{'yes' if f.accepted else 'no'}</td>"
        f"<td>{'' if f.residual is None else f'{100 * f.residual:.1f}'}</td><td>{f.inliers}</td>"
        f"<td>{f.seconds:.1f}</td><td>{html.escape(f.reason or (f.depth.reason if f.depth else ''))}</td></tr>"
        for f in result.frames)
    seen = [s for s in states.values() if s.status is not ElementStatus.NOT_OBSERVED]
    verdicts = "".join(
        f"<tr><td>{html.escape(s.family or '-')}</td><td>{s.global_id}</td><td>{s.status.value}</td>"
        f"<td>{'' if s.deviation is None else f'{100 * s.deviation.translation:.1f}'}</td></tr>" for s in seen)
    warnings = "".join(f"<p class='warn'>{html.escape(w)}</p>" for w in result.warnings)
    return ("<!doctype html><html><head><meta charset='utf-8'><title>bim2rdt verify</title><style>body{font-family:"
            "sans-serif;margin:2em}td,th{padding:2px 8px;border-bottom:1px solid #ddd}.warn{color:#b00}</style>"
            f"</head><body><h1>bim2rdt verify</h1>{warnings}<h2>Frames</h2><table><tr><th>#</th><th>source</th>"
            "<th>accepted</th><th>residual cm</th><th>inliers</th><th>s</th><th>note</th></tr>"
            f"{rows}</table><h2>Elements</h2><table><tr><th>family</th><th>GlobalId</th><th>status</th>"
            f"<th>shift cm</th></tr>{verdicts}</table></body></html>")
