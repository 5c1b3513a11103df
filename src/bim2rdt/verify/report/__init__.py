"""verify's report and the pictures behind it and behind the BCF topics: the frames' small copies
(:mod:`.capture`), outlines and heat maps (:mod:`.overlay`), the plan (:mod:`.plan`), the element rows
(:mod:`.rows`), each issue's view (:mod:`.topics`) and the page (:mod:`.page`)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from bim2rdt.atomic import write_bytes_atomic
from bim2rdt.bim import BimModel
from bim2rdt.twin import ElementState
from bim2rdt.twin import TopicView
from bim2rdt.verify.report.capture import FrameCapture, FrameView
from bim2rdt.verify.report.topics import frame_words, topic_views

__all__ = ["FrameCapture", "FrameView", "frame_words", "topic_views", "write_report"]


def write_report(result, states: Mapping[str, ElementState], model: BimModel, folder: Path,
                 views: Mapping[int, FrameView], topics: Mapping[str, TopicView], title: str) -> Path:
    """Write ``folder/report.html`` (what else the run left in ``folder`` is shown too: structure.json,
    progress.json, deviation/*.png).

    Args:
        result: verify's result (``frames``, ``warnings``).
        states: The twin's states by GlobalId.
        model: The BIM.
        folder: The run's folder.
        views: The frames' small copies by index.
        topics: Each issue's BCF view by GlobalId.
        title: The page's heading.

    Returns:
        The page's path.
    """
    from bim2rdt.planning import OccupancyGrid, PlanningError
    from bim2rdt.verify.report.page import ReportData, read_run_files, report_page
    from bim2rdt.verify.report.pictures import frame_pictures, frame_residuals
    from bim2rdt.verify.report.plan import plan_png
    from bim2rdt.verify.report.rows import element_rows
    from bim2rdt.verify.report.sizes import new_object_sizes

    structure, progress, heat = read_run_files(folder)
    try:
        plan = plan_png(model, states, result.frames, OccupancyGrid.from_bim(model))
    except PlanningError:  # a model without a storey to slice: the page goes without a plan
        plan = None
    residuals = frame_residuals(result.frames, model, views)
    data = ReportData(title, result.frames, element_rows(dict(states), result.frames, model), states, plan,
                      frame_pictures(result.frames, states, model, views, residuals, heat), topics,
                      result.warnings + result.source_warnings, structure, progress,
                      _read(folder / "progress_structure.png"), heat,
                      new_object_sizes(states, result.frames, views, residuals),
                      {el.global_id: el.name or "" for el in model.elements})
    return write_bytes_atomic(folder / "report.html", report_page(data).encode("utf-8"))


def _read(path: Path) -> bytes | None:
    try:
        return path.read_bytes()
    except OSError:
        return None
