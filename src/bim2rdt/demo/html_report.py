"""The site day as one self-contained HTML page (``report.html`` beside ``report.md``): every image inline as a
data URI, links to the files written beside it (the twin IFC, the BCF issues, the Nav2 map, the JSON).

Sections: the plan map (walls, objects coloured by twin status, the robot's paths, stations, zones), the
deviation table with the tolerance preset each element was judged by, ICP vs SG-ICP on the paper's scenarios,
and each worker's A(8) against the EAV and ELV. The page takes plain inputs, so any run (the embedded site,
another IFC building) can fill it.
"""

from __future__ import annotations

import base64
import html
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

from bim2rdt.atomic import write_bytes_atomic
from bim2rdt.safety import EAV, ELV
from bim2rdt.twin import STATUS_COLOURS, ElementState, ElementStatus, TolerancePolicy

STYLE = """body{font-family:system-ui,sans-serif;margin:2em auto;max-width:min(1800px,96vw);padding:0 1em;color:#222}
.scroll{overflow-x:auto}table{border-collapse:collapse;margin:.5em 0 1.5em;font-size:.85em}
th,td{border:1px solid #ccc;padding:.2em .5em;text-align:right;white-space:nowrap}th{background:#f3f3f3}
td.l,th.l{text-align:left}td.l{white-space:normal;min-width:8em}img{max-width:100%;border:1px solid #ddd}
.badge{display:inline-block;padding:0 .5em;border-radius:.6em;color:#fff;font-size:.85em}.note{color:#666}
.fail{color:#b00}.ok{color:#070}"""


@dataclass(frozen=True)
class WorkerExposure:
    """One worker's day: pseudonym, A(8) (m/s^2) and HSE points."""

    worker: str
    a8: float
    points: float


@dataclass
class HtmlReport:
    """What the page shows. ``images`` are PNG bytes by caption; ``links`` are file names (beside the page) by
    label; ``registration`` is a run of the registration scenarios (``evaluation.runs``), or None."""

    title: str
    summary: Sequence[str] = ()
    plan_png: bytes | None = None
    states: Mapping[str, ElementState] = field(default_factory=dict)
    tolerances: TolerancePolicy | None = None
    registration: object | None = None
    exposure_png: bytes | None = None
    workers: Sequence[WorkerExposure] = ()
    links: Mapping[str, str] = field(default_factory=dict)
    notes: Sequence[str] = ()
    sections: Sequence[tuple[str, str]] = ()
    """More sections (title, HTML), after the deviations: the robot's route, its localization, safety events."""


def write_html_report(report: HtmlReport, path: Path) -> Path:
    """Write the page atomically; returns ``path``."""
    body = [f"<h1>{_e(report.title)}</h1>", *(f"<p>{_e(line)}</p>" for line in report.summary),
            _links(report.links), _section("Plan map", _image(report.plan_png, "plan map")),
            _section("Deviations against the BIM", deviation_table(report.states) + preset_table(report.tolerances)),
            *(_section(title, content) for title, content in report.sections),
            _section("Registration: ICP vs SG-ICP", registration_table(report.registration)),
            _section("Hand-arm vibration: A(8) per worker", exposure_table(report.workers)
                     + _image(report.exposure_png, "A(8) through the day")),
            *(f'<p class="note">{_e(note)}</p>' for note in report.notes)]
    page = (f"<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>{_e(report.title)}</title>"
            f"<style>{STYLE}</style></head><body>{''.join(body)}</body></html>")
    return write_bytes_atomic(Path(path), page.encode("utf-8"))


def deviation_table(states: Mapping[str, ElementState]) -> str:
    """One row per observed element (anything but not observed): status, deviation, preset, fit, evidence."""
    observed = sorted((s for s in states.values() if s.status is not ElementStatus.NOT_OBSERVED),
                      key=lambda s: (s.status.value, s.family or "", s.global_id))
    if not observed:
        return '<p class="note">No element observed.</p>'
    header = ("element", "class", "GlobalId", "status", "shift cm", "tilt °", "yaw °", "tolerance", "fitness",
              "rmse cm", "robot", "station", "seen (UTC)")
    rows = [_deviation_row(state) for state in observed]
    not_observed = sum(s.status is ElementStatus.NOT_OBSERVED for s in states.values())
    return _table(header, rows, left=4) + f'<p class="note">{not_observed} BIM elements not observed.</p>'


def _deviation_row(state: ElementState) -> list[str]:
    d, t, f, e = state.deviation, state.tolerance, state.fit, state.evidence
    return [_e(state.family or "-"), _e(state.ifc_class or "not in BIM"), f"<code>{_e(state.global_id)}</code>",
            _badge(state.status),
            _num(d and 100 * d.translation, 1), _num(d and d.tilt_deg, 1), _num(d and d.yaw_deg, 1),
            _e(f"{t.name} ({100 * t.translation:g} cm / {t.rotation_deg:g}°)") if t else "-",
            _num(f and f.fitness, 2), _num(100 * f.rmse if f and f.rmse is not None else None, 2), _e(state.robot or "-"),
            _e("-" if e is None or e.station is None else str(e.station + 1)),  # 1 first, as on the maps
            _e(datetime.fromtimestamp(e.time, timezone.utc).strftime("%H:%M:%S") if e else "-")]


def preset_table(tolerances: TolerancePolicy | None) -> str:
    """The tolerance presets and what they apply to."""
    if tolerances is None:
        return ""
    rows = []
    for name, preset in tolerances.presets.items():
        applies = [c for c, p in tolerances.classes.items() if p == name]
        applies += [f for f, p in tolerances.families.items() if p == name]
        applies += ["anything else"] if tolerances.default == name else []
        rows.append([_e(name), f"{100 * preset.translation:g}", f"{preset.rotation_deg:g}", _e(", ".join(applies))])
    return "<h3>Tolerance presets</h3>" + _table(("preset", "shift cm", "tilt / yaw °", "applies to"), rows, left=1,
                                                 left_last=True)


def registration_table(run) -> str:
    """Per scenario: Hausdorff RMSE of ICP and SG-ICP, the cut, success rates, and the before/after plots."""
    if run is None:
        return '<p class="note">Registration scenarios not run.</p>'
    rows = []
    for result in run.results:
        icp, sg = result.stats["ICP"], result.stats["SG-ICP"]
        cut = 100.0 * (icp.rmse - sg.rmse) / icp.rmse if icp.rmse > 0 else 0.0
        rows.append([_e(result.name), _e(result.description), f"{icp.rmse:.4f}", f"{sg.rmse:.4f}", f"{cut:+.1f} %",
                     f"{icp.success:.0%}", f"{sg.success:.0%}", f"{icp.time_ms:.1f}", f"{sg.time_ms:.1f}"])
    header = ("scenario", "what", "ICP RMSE m", "SG-ICP RMSE m", "cut", "ICP success", "SG-ICP success",
              "ICP ms", "SG-ICP ms")
    plots = "".join(_image(Path(p).read_bytes(), Path(p).stem) for p in getattr(run, "plots", ()) if Path(p).exists())
    return (_table(header, rows, left=2) + f'<p class="note">{run.trials} seeded trials per scenario (a quick look; '
            "the paper's targets are judged by <code>bim2rdt bench registration</code>).</p>" + plots)


def exposure_table(workers: Sequence[WorkerExposure]) -> str:
    """Each worker's A(8) and points against the exposure action value (2.5 m/s²) and limit value (5 m/s²)."""
    if not workers:
        return '<p class="note">No vibration exposure recorded.</p>'
    rows = []
    for w in workers:
        verdict = ("above the ELV" if w.a8 >= ELV else "above the EAV" if w.a8 >= EAV else "below the EAV")
        css = "fail" if w.a8 >= EAV else "ok"
        rows.append([f"<code>{_e(w.worker)}</code>", f"{w.a8:.2f}", f"{w.points:.0f}", f"{100 * w.a8 / EAV:.0f} %",
                     f'<span class="{css}">{verdict}</span>'])
    return _table(("worker", "A(8) m/s²", "HSE points", "of EAV", f"EAV {EAV:g} / ELV {ELV:g} m/s²"), rows, left=1)


def plain_table(header: Sequence[str], rows: Sequence[Sequence[object]], left: int = 1,
                left_last: bool = False) -> str:
    """A table of plain values (escaped here), for sections other modules fill."""
    return _table(header, [[_e(v) for v in row] for row in rows], left=left, left_last=left_last)


def _section(title: str, content: str) -> str:
    return f"<h2>{_e(title)}</h2>{content}"


def _links(links: Mapping[str, str]) -> str:
    if not links:
        return ""
    items = "".join(f'<li><a href="{_e(target)}">{_e(label)}</a> (<code>{_e(target)}</code>)</li>'
                    for label, target in links.items())
    return f"<h2>Files</h2><ul>{items}</ul>"


def _image(png: bytes | None, caption: str) -> str:
    if not png:
        return f'<p class="note">No {_e(caption)}.</p>'
    data = base64.b64encode(png).decode("ascii")
    return f'<figure><img alt="{_e(caption)}" src="data:image/png;base64,{data}"><figcaption>{_e(caption)}' \
           "</figcaption></figure>"


def _badge(status: ElementStatus) -> str:
    import matplotlib.colors

    return f'<span class="badge" style="background:{matplotlib.colors.to_hex(STATUS_COLOURS[status])}">' \
           f"{_e(status.value)}</span>"


def _table(header: Sequence[str], rows: Sequence[Sequence[str]], left: int = 1, left_last: bool = False) -> str:
    def cells(values, tag):
        return "".join(f'<{tag}{_align(i, len(values), left, left_last)}>{v}</{tag}>' for i, v in enumerate(values))

    body = "".join(f"<tr>{cells(row, 'td')}</tr>" for row in rows)
    return f"<div class=\"scroll\"><table><tr>{cells([_e(h) for h in header], 'th')}</tr>{body}</table></div>"


def _align(index: int, count: int, left: int, left_last: bool) -> str:
    return ' class="l"' if index < left or (left_last and index == count - 1) else ""


def _num(value: float | None, digits: int) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def _e(text: str) -> str:
    return html.escape(str(text), quote=True)
