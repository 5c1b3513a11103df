"""What ``verify`` writes into its folder: the twin (``twin.db``, exported as ``twin.json``, ``twin.ifc`` and
``issues.bcf``: each issue seen from the frame that saw it), ``localization.json`` and ``report.html``
(:mod:`bim2rdt.verify.report`)."""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from bim2rdt.atomic import write_bytes_atomic
from bim2rdt.bim import BimModel
from bim2rdt.twin import (DigitalTwin, ElementState, ElementStatus, ProgressConfig, TwinConfig, TwinError,
                          read_structure_statuses, write_bcf, write_progress)
from bim2rdt.verify.chain import VerifyResult, family_priors
from bim2rdt.verify.report import FrameView, topic_views, write_report

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
    """A fresh twin at ``out_dir/twin.db``: each frame's observation of every element judged at all (the history),
    then each element's verdict from all its frames (:mod:`.fusion`: its fused observation, or its place seen
    empty), then the new objects merged over the frames (transient clusters are not recorded). Time: the
    frame's, else its index; camera: the fixed pose.

    Args:
        result: What verify found in every frame.
        model: The BIM the twin is of.
        out_dir: The verify folder; a twin.db already there is replaced. The rebuild is a run of the store
            (``DigitalTwin.open(run=...)``), marked finished after its last record: a twin.db a kill cut short is
            refused as partial by ``twin state``.
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
                            symmetry=dict(symmetry), min_fitness=config.min_fitness, robot=robot, run=robot)
    frames = {frame.index: frame for frame in result.frames}
    judged = {e.global_id for e in result.elements if e.status is not ElementStatus.NOT_OBSERVED}
    for frame in result.frames:  # the history: each frame's own observation of each element judged at all
        for observation in frame.observations:
            if observation.global_id in judged:
                twin.record(observation, _when(frame), camera=frame.pose)
    for element in result.elements:  # the verdict: from all the frames that saw it
        last = frames[element.frames[-1]]
        if element.status is ElementStatus.MISSING:
            twin.mark_missing(element.global_id, _when(last), frames=element.frames, camera=last.pose)
        elif element.observation is not None:
            twin.record(element.observation, _when(last), camera=last.pose)
    for cluster in result.new:
        last = frames[cluster.frames[-1]]
        twin.record(cluster.observation, _when(last), camera=last.pose)
    twin.finish_run()  # last: a store a kill cut short says it is partial when read
    return twin


def _when(frame) -> float:
    """A frame's time for the twin: its own, else its index (s)."""
    return frame.time if frame.time is not None else float(frame.index)


def write_outputs(result: VerifyResult, twin: DigitalTwin, out_dir: Path,
                  views: Mapping[int, FrameView] | None = None, title: str = "bim2rdt verify",
                  progress: ProgressConfig = ProgressConfig()) -> VerifyFiles:
    """Write every file of the verify folder (a run's staging folder: :class:`~bim2rdt.verify.output_set.OutputSet`
    moves them into ``--out``); with a work schedule in the model also progress.json (and its curve and structure
    view), with ``structure.json``'s judgements where the folder has one.

    Args:
        result: What verify found in every frame.
        twin: The twin :func:`record_twin` made of it.
        out_dir: The folder to write into.
        views: The frames' small copies by index (:class:`~bim2rdt.verify.report.FrameCapture`): the BCF
            snapshots and the report's pictures; None: rendered snapshots and no frame pictures.
        title: The report's heading.
        progress: When a task of the schedule is behind or ahead.

    Returns:
        The paths of twin.json, issues.bcf, localization.json, report.html and twin.ifc (None, with a note,
            when the model cannot be written back).
    """
    views = views or {}
    localization = write_bytes_atomic(out_dir / "localization.json", json.dumps(
        {"frames": [f.to_dict() for f in result.frames], "miscalibrated": result.miscalibrated,
         "warnings": result.warnings + result.source_warnings, "dropped": result.dropped,
         "dropped_counts": result.drop_counts,
         "elements": [{"global_id": e.global_id, "status": "by pose" if e.status is None else e.status.value,
                       "reason": e.reason, "frames": list(e.frames), "sigma": e.sigma} for e in result.elements],
         "transient": [{"centre": [round(float(v), 3) for v in c.observation.pose[:3, 3]], "frames": list(c.frames),
                        "reason": c.transient} for c in result.transient]}, indent=1).encode())
    states = twin.state()
    topics = topic_views(states, result.frames, views, twin.model)
    bcf = write_bcf(twin.model, states, out_dir / "issues.bcf", twin.object_mesh, views=topics)
    files = VerifyFiles(twin.export_json(out_dir / "twin.json"), bcf, localization, out_dir / "report.html", None)
    try:
        files.ifc = twin.export_ifc(out_dir / "twin.ifc")
    except TwinError as error:
        files.ifc_note = str(error)
    written = write_progress(twin, out_dir, twin_ifc=files.ifc,
                             structure=read_structure_statuses(out_dir / "structure.json"),
                             behind_percent=progress.behind_percent, ahead_percent=progress.ahead_percent)
    files.progress = written.progress_json if written is not None else None
    write_report(result, states, twin.model, out_dir, views, topics, title)
    return files


def verdict_counts(states: dict[str, ElementState]) -> dict[str, int]:
    """{status: number of elements} over every status (zero included); "not built" (a permanent element's,
    counted by verify's ``structure`` apart) only when some element is.

    Args:
        states: The twin's states by GlobalId.

    Returns:
        The counts by status value.
    """
    counts = {s.value: 0 for s in ElementStatus if s is not ElementStatus.NOT_BUILT}
    for state in states.values():
        counts[state.status.value] = counts.get(state.status.value, 0) + 1
    return counts
