"""The progress section of a report, from ``progress.json``: the task table coloured by status with a bar per task
over the schedule's dates (Gantt-like), the S-curve of planned against observed (``progress_curve.json``), and
the structure in 3-D coloured built / not built / not observed. Images are embedded (data URIs): the section
needs no other file. ``verify``'s report and the demo's call :func:`progress_section_html`.
"""

from __future__ import annotations

import base64
import html
import io
from collections.abc import Mapping, Sequence
from datetime import datetime

import numpy as np

TASK_COLOURS = {"complete": "#2ca02c", "ahead": "#17becf", "in progress": "#1f77b4", "not started": "#c7c7c7",
                  "behind": "#d62728", "unknown": "#8c8c8c"}
"""One colour per task status (tables, bars)."""
BUILT_COLOURS = {"built": "#2ca02c", "not built": "#d62728", "not observed": "#bdbdbd"}
"""One colour per product state in the structure view."""


def progress_section_html(progress: Mapping, curve: Mapping | None = None, structure_png: bytes | None = None,
                          heading: bool = True) -> str:
    """The progress section: heading, task table with status colours and schedule bars, the S-curve, the
    structure view.

    Args:
        progress: progress.json's content.
        curve: progress_curve.json's content ({"points": [...]}); None leaves the S-curve out.
        structure_png: A PNG of the structure (see :func:`structure_png`); None leaves it out.
        heading: Wrap it in a ``<section>`` with an ``<h2>`` naming the schedule; False gives the body only (for a
            report that titles its sections itself).

    Returns:
        An HTML fragment, images embedded.
    """
    schedule = progress["schedule"]
    title = html.escape(schedule.get("name") or schedule["global_id"])
    parts = [f"<p>Schedule {title} at {html.escape(progress['date'])}. {_summary(progress['tasks'])}</p>",
             _task_table(progress)]
    if curve is not None and curve.get("points"):
        parts.append(_img(s_curve_png(curve["points"], progress["date"]), "S-curve: planned against observed"))
    if structure_png is not None:
        parts.append(_img(structure_png, "The structure: built, not built, not observed"))
    body = "".join(parts)
    return f"<section id='progress'><h2>Progress: {title}</h2>{body}</section>" if heading else body


def progress_markdown(progress: Mapping) -> str:
    """The task table as Markdown (report.md, the CLI's plain output).

    Args:
        progress: progress.json's content.

    Returns:
        A Markdown table, one row per task (nested tasks indented).
    """
    rows = ["| task | planned | observed | status | products (as planned / deviating / not built / not observed) |",
            "|---|---:|---:|---|---|"]
    depth = _depths(progress["tasks"])
    for task in progress["tasks"]:
        counts = task["products"]
        rows.append(f"| {'  ' * depth[task['global_id']]}{task['identification'] or ''} {task['name'] or ''} | "
                    f"{_percent(task['planned_percent'])} | {_percent(task['observed_percent'])} | {task['status']} | "
                    f"{counts['as planned']} / {counts['deviating']} / {counts['not built']} / "
                    f"{counts['not observed']} |")
    return "\n".join(rows) + "\n"


def _summary(tasks: Sequence[Mapping]) -> str:
    counts: dict[str, int] = {}
    for task in tasks:
        if not task["children"]:
            counts[task["status"]] = counts.get(task["status"], 0) + 1
    return "Tasks: " + ", ".join(f"{n} {status}" for status, n in sorted(counts.items())) + "."


def _task_table(progress: Mapping) -> str:
    tasks = progress["tasks"]
    dates = [_date(t[k]) for t in tasks for k in ("planned_start", "planned_finish") if t[k]]
    first, last = (min(dates), max(dates)) if dates else (None, None)
    depth = _depths(tasks)
    rows = []
    for task in tasks:
        colour = TASK_COLOURS.get(task["status"], "#8c8c8c")
        name = html.escape(f"{task['identification'] or ''} {task['name'] or ''}".strip())
        weight = "bold" if task["children"] else "normal"
        counts = task["products"]
        rows.append(
            f"<tr><td style='padding-left:{8 + 16 * depth[task['global_id']]}px;font-weight:{weight}'>{name}</td>"
            f"<td>{html.escape((task['planned_start'] or '')[:10])}</td>"
            f"<td>{html.escape((task['planned_finish'] or '')[:10])}</td>"
            f"<td style='width:30%'>{_bar(task, first, last, progress['date'], colour)}</td>"
            f"<td>{_percent(task['planned_percent'])}</td><td>{_percent(task['observed_percent'])}</td>"
            f"<td style='background:{colour};color:white'>{html.escape(task['status'])}</td>"
            f"<td>{counts['as planned']} / {counts['deviating']} / {counts['not built']} / {counts['not observed']}"
            "</td></tr>")
    return ("<table class='progress'><tr><th>task</th><th>start</th><th>finish</th><th>schedule</th><th>planned</th>"
            "<th>observed</th><th>status</th><th title='as planned / deviating / not built / not observed'>products"
            "</th></tr>" + "".join(rows) + "</table>")


def _bar(task: Mapping, first: datetime | None, last: datetime | None, now: str, colour: str) -> str:
    """A task's scheduled span as a bar on the schedule's time axis, filled to its observed percentage, with a
    line at the progress date."""
    if first is None or last is None or last <= first or not task["planned_start"] or not task["planned_finish"]:
        return ""
    span = (last - first).total_seconds()

    def x(value: datetime) -> float:
        return max(0.0, min(100.0, 100.0 * (value - first).total_seconds() / span))

    left, right = x(_date(task["planned_start"])), x(_date(task["planned_finish"]))
    fill = (task["observed_percent"] or 0.0) / 100.0
    return (f"<div style='position:relative;height:14px;background:#f3f3f3'>"
            f"<div style='position:absolute;left:{left:.2f}%;width:{max(right - left, 0.5):.2f}%;height:14px;"
            f"border:1px solid {colour};box-sizing:border-box'><div style='width:{100 * fill:.1f}%;height:100%;"
            f"background:{colour}'></div></div><div style='position:absolute;left:{x(_date(now)):.2f}%;top:-2px;"
            "width:2px;height:18px;background:black'></div></div>")


def s_curve_png(points: Sequence[Mapping], now: str | None = None) -> bytes:
    """The S-curve: planned and observed percentage of the whole schedule over time.

    Args:
        points: progress_curve.json's points ({"date", "planned_percent", "observed_percent"}).
        now: The progress date (ISO 8601), drawn as a vertical line; None draws none.

    Returns:
        A PNG.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dates = [_date(p["date"]) for p in points]
    figure, axes = plt.subplots(figsize=(7.5, 3.2), dpi=100)
    planned = [(d, p["planned_percent"]) for d, p in zip(dates, points) if p["planned_percent"] is not None]
    observed = [(d, p["observed_percent"]) for d, p in zip(dates, points) if p["observed_percent"] is not None]
    if planned:
        axes.plot(*zip(*planned), color="#1f77b4", label="planned")
    if observed:
        axes.step(*zip(*observed), where="post", color="#d62728", marker="o", markersize=3, label="observed")
    if now:
        axes.axvline(_date(now), color="black", linewidth=0.8, linestyle=":")
    axes.set_ylim(0, 105)
    axes.set_ylabel("% of the schedule's quantity")
    axes.legend(loc="upper left")
    axes.grid(alpha=0.3)
    figure.autofmt_xdate()
    return _png(figure)


def structure_png(meshes: Mapping[str, tuple[np.ndarray, np.ndarray]], states: Mapping[str, str]) -> bytes:
    """The structure on plan, each element's footprint coloured built (as planned or deviating), not built, or not
    observed; lower elements first, so walls and columns show over the slab (drawn pale).

    Args:
        meshes: {GlobalId: (vertices (N,3) world metres, faces (M,3))} of the elements to draw.
        states: {GlobalId: product state} ("as planned", "deviating", "not built", "not observed").

    Returns:
        A PNG.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch, Polygon

    figure, axes = plt.subplots(figsize=(7.5, 5.5), dpi=100)
    drawn = sorted(((vertices[:, 2].max(), global_id, vertices) for global_id, (vertices, faces) in meshes.items()
                    if len(faces)), key=lambda item: item[0])
    for _, global_id, vertices in drawn:
        key = _state_key(states.get(global_id))
        flat = np.ptp(vertices[:, 2]) < 0.5  # slabs: pale, so the walls and columns on them stand out
        axes.add_patch(Polygon(_footprint(vertices[:, :2]), closed=True, facecolor=BUILT_COLOURS[key],
                               alpha=0.3 if flat else 1.0, edgecolor="0.25", linewidth=0.5,
                               hatch="//" if key == "not built" else None))
    if drawn:
        every = np.concatenate([vertices[:, :2] for _, _, vertices in drawn])
        (x0, y0), (x1, y1) = every.min(axis=0), every.max(axis=0)
        margin = 0.03 * max(x1 - x0, y1 - y0, 1.0)
        axes.set_xlim(x0 - margin, x1 + margin)
        axes.set_ylim(y0 - margin, y1 + margin)
    axes.set_aspect("equal")
    axes.set_xlabel("x (m)")
    axes.set_ylabel("y (m)")
    axes.set_title("Structure: built / not built / not observed")
    axes.legend(handles=[Patch(color=c, label=k) for k, c in BUILT_COLOURS.items()], loc="upper left",
                bbox_to_anchor=(1.01, 1.0))
    return _png(figure)


def _footprint(points_xy: np.ndarray) -> np.ndarray:
    """The convex hull of an element's plan points, (K,2) metres."""
    from scipy.spatial import ConvexHull, QhullError

    unique = np.unique(np.round(points_xy, 4), axis=0)
    try:
        return unique[ConvexHull(unique).vertices]
    except (QhullError, ValueError):
        return unique


def _state_key(state: str | None) -> str:
    if state in ("as planned", "deviating"):
        return "built"
    return "not built" if state in ("not built", "missing") else "not observed"


def _depths(tasks: Sequence[Mapping]) -> dict[str, int]:
    parents = {child: task["global_id"] for task in tasks for child in task["children"]}
    depth: dict[str, int] = {}
    for task in tasks:
        level, node = 0, task["global_id"]
        while node in parents and level < 64:
            node, level = parents[node], level + 1
        depth[task["global_id"]] = level
    return depth


def _date(text: str) -> datetime:
    return datetime.fromisoformat(text)


def _percent(value: float | None) -> str:
    return "-" if value is None else f"{value:.1f} %"


def _png(figure) -> bytes:
    import matplotlib.pyplot as plt

    buffer = io.BytesIO()
    figure.tight_layout()
    figure.savefig(buffer, format="png")
    plt.close(figure)
    return buffer.getvalue()


def _img(png: bytes, alt: str) -> str:
    return (f"<figure><img alt='{html.escape(alt)}' src='data:image/png;base64,{base64.b64encode(png).decode()}'>"
            f"<figcaption>{html.escape(alt)}</figcaption></figure>")
