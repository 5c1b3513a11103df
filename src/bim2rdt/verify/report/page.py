"""verify's report.html: one self-contained page (every image a data URI) that a site manager can forward.

From the top: the verdict counts and warnings; the plan (:mod:`.plan`); one row per observed element (name,
family, class, status and why, shift x/y/z, tilt, yaw, coverage, the frames that saw it, its BCF topic); the new
objects with their position and size; the BCF topics with their snapshots; each frame (its image with the
outlines of the elements it saw, its depth residual heat map, its fix: accepted, free directions, residual, depth
check); and, when the run has them, the structure (``structure.json``) and the schedule (``progress.json``).
"""

from __future__ import annotations

import base64
import html
import io
import json
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bim2rdt.perception import UNKNOWN_FAMILY
from bim2rdt.twin import STATUS_COLOURS, ElementState, ElementStatus
from bim2rdt.twin import TopicView, topic_title
from bim2rdt.verify.report.rows import ElementRow
from bim2rdt.verify.report.topics import frame_words

PHOTO_QUALITY = 85
"""JPEG quality of the frames' pictures in the page (the BCF keeps PNG snapshots)."""
MAX_FRAME_CARDS = 60
"""Frames drawn with pictures (the first ones, and every frame with a finding); the rest are in the table only."""
STYLE = ("body{font-family:system-ui,sans-serif;margin:1.5em;color:#222;max-width:1400px}h2{margin-top:1.6em}"
         "table{border-collapse:collapse;font-size:13px}td,th{padding:3px 8px;border-bottom:1px solid #ddd;"
         "text-align:right;vertical-align:top}td.l,th.l{text-align:left}td.l{overflow-wrap:anywhere;min-width:6em}.warn{color:#b00}"
         ".badge{display:inline-block;padding:1px 6px;border-radius:3px;color:#fff}"
         ".card{display:inline-block;vertical-align:top;margin:0 1em 1.2em 0;max-width:680px}"
         ".card img,.topic img{max-width:100%;display:block}.pics{display:flex;gap:8px}.pics figure{margin:0;flex:0 0 320px}"
         ".pics img{width:320px}"
         ".topic{display:inline-block;vertical-align:top;width:330px;margin:0 1em 1em 0;font-size:13px}"
         "img.plan{max-width:100%}.small{font-size:12px;color:#555;overflow-wrap:anywhere}")


@dataclass
class FramePictures:
    """A frame's pictures (PNG bytes): ``image`` with outlines, ``heat`` map, and what the heat map is."""

    image: bytes | None = None
    heat: bytes | None = None
    heat_note: str = ""


@dataclass
class ReportData:
    """Everything the page shows (see the module's note)."""

    title: str
    frames: Sequence
    rows: list[ElementRow]
    states: Mapping[str, ElementState]
    plan: bytes | None = None
    pictures: Mapping[int, FramePictures] = field(default_factory=dict)
    topics: Mapping[str, TopicView] = field(default_factory=dict)
    warnings: Sequence[str] = ()
    structure: list | None = None
    progress: dict | None = None
    progress_png: bytes | None = None
    """The structure on plan, built / not built (``progress_structure.png``), when the run has it."""
    extra_heat: Mapping[str, bytes] = field(default_factory=dict)
    sizes: Mapping[str, tuple[int, np.ndarray]] = field(default_factory=dict)
    """New objects' (frame index, size x, y, z in metres) as a frame measured them (:mod:`.sizes`)."""
    names: Mapping[str, str] = field(default_factory=dict)
    """The BIM's element names by GlobalId (the structure table names what it judged, seen or not)."""


def report_page(data: ReportData) -> str:
    """The whole page.

    Args:
        data: What it shows.

    Returns:
        The HTML text.
    """
    sections = [_summary(data), _plan(data), _elements(data), _new_objects(data), _topics(data), _frames(data),
                _structure(data.structure, data.names), _schedule(data.progress, data.progress_png), _extra_heat(data.extra_heat)]
    return (f"<!doctype html><html><head><meta charset='utf-8'><title>{_e(data.title)}</title>"
            f"<style>{STYLE}</style></head><body><h1>{_e(data.title)}</h1>{''.join(sections)}</body></html>")


def read_run_files(folder: Path) -> tuple[list | None, dict | None, dict[str, bytes]]:
    """What other stages left in the run's folder: ``structure.json``, ``progress.json`` and the heat maps in
    ``deviation/`` (PNG bytes by file name); None / empty where absent or unreadable.

    Args:
        folder: The run's (staging) folder.

    Returns:
        (structure, progress, heat maps).
    """
    def load(name: str):
        try:
            return json.loads((folder / name).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None

    heat = {p.name: p.read_bytes() for p in sorted((folder / "deviation").glob("*.png"))} \
        if (folder / "deviation").is_dir() else {}
    structure = load("structure.json")
    if isinstance(structure, dict):
        structure = structure.get("elements")
    return (structure if isinstance(structure, list) else None), load("progress.json"), heat


def frame_heat(heat: Mapping[str, bytes], index: int) -> bytes | None:
    """The heat map of frame ``index`` among ``deviation/``'s PNGs: the one whose name's last number is it.

    Args:
        heat: PNG bytes by file name.
        index: The frame's index.

    Returns:
        The PNG, or None.
    """
    for name, png in heat.items():
        numbers = re.findall(r"\d+", Path(name).stem)
        if numbers and int(numbers[-1]) == index:
            return png
    return None


def _summary(data: ReportData) -> str:
    counts: dict[str, int] = {}
    for state in data.states.values():
        counts[state.status.value] = counts.get(state.status.value, 0) + 1
    fixed = sum(f.accepted for f in data.frames)
    words = ", ".join(f"{_badge(ElementStatus(k))} {v}" for k, v in counts.items()
                      if k != ElementStatus.NOT_OBSERVED.value)
    warnings = "".join(f"<p class='warn'>{_e(w)}</p>" for w in data.warnings)
    frames = f"{len(data.frames)} frame" + ("" if len(data.frames) == 1 else "s")
    return (f"<p>{frames}, {fixed} localized on the BIM. Verdicts: {words or 'none'}. "
            "Files beside this page: <a href='issues.bcf'>issues.bcf</a>, <a href='twin.json'>twin.json</a>, "
            f"<a href='localization.json'>localization.json</a>.</p>{warnings}")


def _plan(data: ReportData) -> str:
    if data.plan is None:
        return ""
    return f"<h2>Plan</h2><img class='plan' alt='plan' src='{_uri(data.plan)}'>"


def _elements(data: ReportData) -> str:
    header = ("name", "family", "class", "status", "why", "dx cm", "dy cm", "dz cm", "tilt °", "yaw °",
              "coverage", "frames", "BCF")
    rows = "".join(_element_row(row, row.state.global_id in data.topics or row.state.status in _ISSUES)
                   for row in data.rows)
    return (f"<h2>Elements ({len(data.rows)} observed)</h2><table id='elements'><tr>"
            + "".join(f"<th class='{'l' if i < 5 else ''}'>{h}</th>" for i, h in enumerate(header))
            + f"</tr>{rows}</table>")


_ISSUES = (ElementStatus.DEVIATING, ElementStatus.MISSING, ElementStatus.NEW)


def _element_row(row: ElementRow, topic: bool) -> str:
    s = row.state
    d = None if s.status is ElementStatus.UNVERIFIED else s.deviation  # a fit too poor to judge says nothing
    shift = ["-"] * 3 if row.shift is None else [f"{100 * v:+.1f}" for v in row.shift]
    link = f"<a href='#topic-{s.global_id}'>topic</a>" if topic else ""
    cells = [f"<td class='l'>{_e(row.name or '-')}<br><span class='small'>{s.global_id}</span></td>",
             f"<td class='l'>{_e(s.family or '-')}</td>", f"<td class='l'>{_e(s.ifc_class or '-')}</td>",
             f"<td class='l'>{_badge(s.status)}</td>", f"<td class='l'>{_e(row.reason)}</td>",
             *(f"<td>{v}</td>" for v in shift),
             f"<td>{'-' if d is None else f'{d.tilt_deg:.1f}'}</td>",
             f"<td>{'-' if d is None else f'{d.yaw_deg:.1f}'}</td>",
             f"<td>{'-' if s.fit is None else f'{100 * s.fit.score:.0f} %'}</td>",
             "<td>" + ", ".join(f"<a href='#frame-{i}'>{i}</a>" for i in row.frames) + "</td>",
             f"<td>{link}</td>"]
    return f"<tr class='element' id='el-{s.global_id}'>{''.join(cells)}</tr>"


def _new_objects(data: ReportData) -> str:
    new = [s for s in data.states.values() if s.status is ElementStatus.NEW and s.pose is not None]
    if not new:
        return ""
    rows = []
    for s in new:
        x, y, z = s.pose[:3, 3]
        size = _size(s, data.sizes.get(s.global_id))
        rows.append(f"<tr><td class='l'><a href='#el-{s.global_id}'>{s.global_id}</a></td>"
                    f"<td class='l'>{_e(s.family or '-')}</td><td>{x:.2f}, {y:.2f}, {z:.2f}</td><td>{size}</td></tr>")
    return ("<h2>New objects</h2><table id='new'><tr><th class='l'>id</th><th class='l'>family</th>"
            "<th>position x, y, z m</th><th>size x, y, z m</th></tr>"
            f"{''.join(rows)}</table><p class='small'>Position: the centre of what was found, on the slab. Size: its "
            "extent in x and y and its height above the slab as the named frame saw it (its hidden side is not in "
            "it), else its family's body.</p>")


def _size(state: ElementState, measured: tuple[int, np.ndarray] | None) -> str:
    if measured is not None:
        index, size = measured
        return " x ".join(f"{v:.2f}" for v in size) + f" (<a href='#frame-{index}'>frame {index}</a>)"
    if state.family == UNKNOWN_FAMILY or state.mesh is None:
        return "not measured"
    return " x ".join(f"{v:.2f}" for v in np.ptp(np.asarray(state.mesh[0], float), axis=0)) + " (its family)"


def _topics(data: ReportData) -> str:
    issues = [s for s in data.states.values() if s.status in _ISSUES]
    if not issues:
        return ""
    cards = []
    for s in sorted(issues, key=lambda s: (s.status.value, s.global_id)):
        view = data.topics.get(s.global_id)
        picture = f"<img alt='snapshot {s.global_id}' src='{_photo_uri(view.snapshot)}'>" if view and view.snapshot \
            else ""
        seen = f"seen in {_e(view.seen)}" if view else "rendered view (no frame image)"
        cards.append(f"<div class='topic' id='topic-{s.global_id}'><b>{_e(topic_title(s))}</b>{picture}"
                     f"<span class='small'>{seen}; <a href='#el-{s.global_id}'>element row</a></span></div>")
    return ("<h2>Issues (BCF topics)</h2><p class='small'>Each topic of <a href='issues.bcf'>issues.bcf</a> opens "
            f"from the sensor that saw it (its pose and field of view) in a BCF viewer.</p>{''.join(cards)}")


def _frames(data: ReportData) -> str:
    header = ("#", "source and time", "prior", "localized", "residual cm", "inliers", "σ xy cm", "free directions",
              "depth check", "note")
    table = "".join(_frame_row(f) for f in data.frames)
    shown = [f for f in data.frames if f.index in data.pictures][:MAX_FRAME_CARDS]
    cards = "".join(_frame_card(f, data.pictures[f.index]) for f in shown)
    return (f"<h2>Frames</h2><table id='frames'><tr>{''.join(f'<th class=l>{h}</th>' for h in header)}</tr>"
            f"{table}</table>{cards}")


def _frame_row(f) -> str:
    sigma = "-"
    if f.covariance is not None:
        worst = float(np.sqrt(max(np.linalg.eigvalsh(np.asarray(f.covariance)[:2, :2]).max(), 0.0)))
        sigma = f"{100 * worst:.1f}" if worst < 1.0 else "free"  # a free direction's sigma is a placeholder
    free = ", ".join("(" + ", ".join(f"{v:.2f}" for v in np.asarray(d)) + ")" for d in f.degenerate) or "none"
    depth = "-" if f.depth is None else (_e(f.depth.reason) or "fine" + (
        f" (median {100 * f.depth.median_residual:.1f} cm)" if f.depth.median_residual is not None else ""))
    return (f"<tr id='row-{f.index}'><td class='l'><a href='#frame-{f.index}'>{f.index}</a></td>"
            f"<td class='l'>{_e(frame_words(f))}</td><td class='l'>{_prior_words(f)}</td>"
            f"<td class='l'>{'yes' if f.accepted else 'no'}</td>"
            f"<td>{'-' if f.residual is None else f'{100 * f.residual:.1f}'}</td><td>{f.inliers}</td>"
            f"<td>{sigma}</td><td class='l'>{free if f.accepted else '-'}</td><td class='l'>{depth}</td>"
            f"<td class='l'>{_e(f.reason)}</td></tr>")


PRIOR_WORDS = {"global": "none: searched on the BIM", "tracked": "the last fix and odometry",
               "source": "the recording's pose", "user": "yours (--prior)"}
"""The frames table's words for where a frame's prior came from (``prior_source``, :mod:`bim2rdt.verify.tracking`)."""


def _prior_words(f) -> str:
    words = PRIOR_WORDS.get(f.prior_source, "-")
    if f.prior_source == "global" and f.resolved_at is not None and f.resolved_at != f.index:
        words += f", resolved at frame {f.resolved_at}"
    elif f.prior_source == "global" and f.places is not None and f.places > 1:
        words += f" ({f.places} places fit)"
    return _e(words)


def _frame_card(f, pictures: FramePictures) -> str:
    images = "".join(f"<figure><img alt='{alt} {f.index}' src='{_photo_uri(png)}'><figcaption class='small'>{cap}"
                     "</figcaption></figure>"
                     for png, alt, cap in ((pictures.image, "frame", "image, the elements it saw outlined"
                                            if f.accepted else "image as recorded"),
                                           (pictures.heat, "heat map", pictures.heat_note)) if png)
    where = "" if f.pose is None else "at " + ", ".join(f"{v:.2f}" for v in f.pose[:3, 3]) + " m"
    return (f"<div class='card' id='frame-{f.index}'><b>{_e(frame_words(f))}</b> "
            f"<span class='small'>{'localized ' + where if f.accepted else 'not localized: ' + _e(f.reason)}</span>"
            f"<div class='pics'>{images}</div></div>")


def _structure(structure: list | None, names: Mapping[str, str]) -> str:
    if not structure:
        return ""
    rows = "".join(
        f"<tr><td class='l'>{_e(names.get(str(e.get('global_id')), '') or '-')}<br><span class='small'>"
        f"{_e(str(e.get('global_id', '')))}</span></td><td class='l'>{_e(str(e.get('ifc_class', '')))}"
        f"</td><td class='l'>{_e(str(e.get('status', '')))}</td><td>{_num(e.get('coverage'), 100, '%')}</td>"
        f"<td>{_num(e.get('median_mm'), 1, '')}</td><td>{_num(e.get('p95_mm'), 1, '')}</td>"
        f"<td>{_num(_length(e.get('offset_m')), 100, '')}</td><td>{_num(e.get('rotation_deg'), 1, '')}</td>"
        f"<td>{_e(', '.join(map(str, e.get('frames') or [])))}</td><td class='l'>{_e(str(e.get('reason') or ''))}"
        "</td></tr>" for e in structure if isinstance(e, dict))
    return ("<h2>Structure</h2><table id='structure'><tr><th class='l'>name</th><th class='l'>class</th>"
            "<th class='l'>status</th><th>coverage</th><th>median mm</th><th>p95 mm</th><th>offset cm</th>"
            f"<th>rotation °</th><th>frames</th><th class='l'>why</th></tr>{rows}</table>")


def _length(offset) -> float | None:
    """The length (m) of an element's (x, y, z) offset; None where no face pinned it."""
    if not isinstance(offset, list | tuple) or len(offset) != 3:
        return None
    return float(np.linalg.norm(np.asarray(offset, dtype=float)))


PROGRESS_COLOURS = {"complete": "#2ca02c", "on schedule": "#2ca02c", "ahead": "#1f77b4", "behind": "#d62728",
                    "not started": "#999999"}


def _schedule(progress: dict | None, png: bytes | None = None) -> str:
    if not isinstance(progress, dict) or not progress.get("tasks"):
        return ""
    rows = []
    for task in progress["tasks"]:
        planned, observed = task.get("planned_percent") or 0, task.get("observed_percent") or 0
        colour = PROGRESS_COLOURS.get(str(task.get("status")), "#ff7f0e")
        bar = (f"<div style='position:relative;width:200px;height:12px;background:#eee'>"
               f"<div style='position:absolute;width:{min(float(planned), 100):.0f}%;height:12px;"
               "border-right:2px solid #000'></div>"
               f"<div style='width:{min(float(observed), 100):.0f}%;height:12px;background:{colour}'></div></div>")
        products = ", ".join(f"{k} {v}" for k, v in (task.get("products") or {}).items() if v)
        rows.append(f"<tr><td class='l'>{_e(str(task.get('identification') or ''))}</td><td class='l'>"
                    f"{_e(str(task.get('name') or ''))}</td><td class='l'>{_e(str(task.get('planned_start') or ''))}"
                    f" – {_e(str(task.get('planned_finish') or ''))}</td><td>{float(planned):.0f} %</td>"
                    f"<td>{float(observed):.0f} %</td><td class='l'>{bar}</td><td class='l'>"
                    f"{_e(str(task.get('status') or ''))}</td><td class='l'>{_e(products)}</td></tr>")
    schedule = progress.get("schedule") or {}
    return (f"<h2>Schedule: {_e(str(schedule.get('name') or ''))} on {_e(str(progress.get('date') or ''))}</h2>"
            "<table id='schedule'><tr><th class='l'>id</th><th class='l'>task</th><th class='l'>planned</th>"
            "<th>planned</th><th>observed</th><th class='l'>observed (bar) against planned (line)</th>"
            f"<th class='l'>status</th><th class='l'>products</th></tr>{''.join(rows)}</table>"
            + (f"<img class='plan' alt='structure built or not' src='{_uri(png)}'>" if png else ""))


def _extra_heat(heat: Mapping[str, bytes]) -> str:
    if not heat:
        return ""
    return "<h2>Deviation heat maps</h2>" + "".join(
        f"<figure class='card'><img alt='{_e(name)}' src='{_uri(png)}'><figcaption class='small'>{_e(name)}"
        "</figcaption></figure>" for name, png in heat.items())


def _num(value, scale: float, unit: str) -> str:
    if not isinstance(value, int | float):
        return "-"
    return f"{scale * value:.1f}{' ' + unit if unit else ''}"


def _badge(status: ElementStatus) -> str:
    import matplotlib.colors

    colour = matplotlib.colors.to_hex(STATUS_COLOURS[status])
    return f"<span class='badge' style='background:{colour}'>{status.value}</span>"


def _uri(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def _photo_uri(png: bytes) -> str:
    """A camera picture as a JPEG data URI: a tenth of its PNG's size (a 640 x 480 frame: ~40 kB, not ~400 kB), so
    a long recording's page stays a size one can mail."""
    from PIL import Image

    buffer = io.BytesIO()
    Image.open(io.BytesIO(png)).convert("RGB").save(buffer, format="JPEG", quality=PHOTO_QUALITY)
    return "data:image/jpeg;base64," + base64.b64encode(buffer.getvalue()).decode("ascii")


def _e(text: str) -> str:
    return html.escape(str(text), quote=True)
