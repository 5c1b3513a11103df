"""The site day's HTML report (``report.html`` beside ``report.md``), assembled from what the day produced: the
plan map and exposure plot the Markdown report drew, the twin's state and presets, the registration run, each
worker's A(8), and links to the files written beside it."""

from __future__ import annotations

import html
from pathlib import Path

from bim2rdt.demo.html_report import HtmlReport, WorkerExposure, write_html_report
from bim2rdt.safety import EAV
from bim2rdt.twin import ElementStatus

LINKS = {"twin IFC (as built)": ("site_twin.ifc",), "BCF issues": ("site_issues.bcf",),
         "twin state (JSON)": ("twin.json",), "BIM (as designed)": ("site.ifc",),
         "Nav2 map": ("nav2/site.yaml", "site.yaml"), "Markdown report": ("report.md",),
         "progress (JSON)": ("progress.json",),
         "run configuration": ("config.json",)}
"""The files the page links to, by label (the first of the candidates present in the folder; absent ones are
left out)."""
PLAN_MAPS = ("plan_map.png", "plan.png")
"""The plan map the page shows: the planner's (walls, objects by twin status, paths, stations, zones) when the
run drew one, else the site report's plan view."""


def write_day_html(day, registration, out_dir: Path) -> Path:
    """Write ``out_dir/report.html`` for a ``SiteDay`` and a registration run (or None); returns its path."""
    states = day.twin.state()
    counts = {status: sum(s.status is status for s in states.values()) for status in ElementStatus}
    summary = [f"Twin: {len(states)} elements; " + ", ".join(f"{n} {status.value}" for status, n in counts.items()
                                                              if n) + ".",
               f"History: {len(day.twin.events())} events in {day.twin.store.label} (observations, status changes "
               "and the HAV monitor's safety events)."]
    if day.twin_files is not None and day.twin_files.ifc_note:
        summary.append(f"IFC write-back: {day.twin_files.ifc_note}")
    plan = next((out_dir / name for name in PLAN_MAPS if (out_dir / name).exists()), None)
    report = HtmlReport("bim2rdt site day", summary=summary, plan_png=_read(plan), states=states,
                        tolerances=day.twin.tolerances, registration=registration,
                        exposure_png=_read(out_dir / "exposure.png"), workers=worker_exposures(day.exposure_timeline),
                        links=present_links(out_dir), sections=day_sections(day))
    return write_html_report(report, out_dir / "report.html")


def day_sections(day) -> list[tuple[str, str]]:
    """What report.md and the terminal tell beyond the deviations: the robot's route and replans, its
    localization, and the HAV monitor's safety events. Stations count from 1, as on the maps."""
    sections = []
    if day.route is not None:
        sections.append(("Robot route and replans", route_html(day.route)))
    if getattr(day, "localization", None) is not None:
        sections.append(("Robot localization", localization_html(day)))
    sections.append(("Safety events (HAV monitor, written to the twin)", safety_html(day.hav_events)))
    if getattr(day, "progress", None) is not None:
        from bim2rdt.demo.progress import progress_html

        sections.append(("Progress against the work schedule", progress_html(day.progress)))
    return sections


def route_html(day_route) -> str:
    from bim2rdt.demo.html_report import plain_table
    from bim2rdt.demo.routes import route_rows

    summary = day_route.summary()
    lines = [f"{summary['stations']} stations planned, {summary.get('visited', summary['stations'])} visited, "
             f"{summary['walked_m']} m walked on planned paths in {summary['minutes']} min."]
    missed = [*summary["unplaced"].values(), *summary["skipped"].values()]
    if missed:
        lines.append("Not visited: " + "; ".join(missed) + ".")
    text = "".join(f"<p>{html.escape(line)}</p>" for line in lines)
    rows = route_rows(day_route)
    return text + (plain_table(("time (UTC)", "at (x, y) m", "why"), rows, left_last=True) if rows
                   else '<p class="note">No replan.</p>')


def localization_html(day) -> str:
    from bim2rdt.demo.html_report import plain_table
    from bim2rdt.demo.localization_report import localization_record, localization_tables

    record = localization_record(day.localization, day.mission, day.reality.truth)
    parts = []
    for title, columns, rows in localization_tables(record):
        if columns and columns[0] == "station":
            rows = [(row[0] + 1, *row[1:]) for row in rows]  # 1 first, as on the maps
        parts.append(f"<h3>{html.escape(title)}</h3>" + plain_table(columns, rows))
    return "".join(parts)


def safety_html(events) -> str:
    from datetime import datetime, timezone

    from bim2rdt.demo.html_report import plain_table

    shown = sorted((e for e in events if not e.kind.endswith("predicted")), key=lambda e: e.time)
    if not shown:
        return '<p class="note">No safety event.</p>'
    rows = [(datetime.fromtimestamp(e.time, timezone.utc).strftime("%H:%M:%S"), e.kind, e.subject,
             f"{e.data.get('day_a8', float('nan')):.2f}") for e in shown]
    return plain_table(("time (UTC)", "event", "worker", "A(8) m/s²"), rows, left=3)


def worker_exposures(timeline) -> list[WorkerExposure]:
    """Each worker's final A(8) of the day (the last point of the monitor's timeline) and its HSE points
    (100 points at the EAV, growing with the square of A(8))."""
    last: dict[str, float] = {}
    for _, subject, a8 in sorted(timeline):
        last[subject] = a8
    return [WorkerExposure(subject, a8, 100.0 * (a8 / EAV) ** 2) for subject, a8 in sorted(last.items())]


def present_links(out_dir: Path) -> dict[str, str]:
    """{label: relative path} of the :data:`LINKS` files present in ``out_dir``."""
    links = {}
    for label, candidates in LINKS.items():
        found = next((name for name in candidates if (out_dir / name).exists()), None)
        if found is not None:
            links[label] = found
    return links


def _read(path: Path | None) -> bytes | None:
    return path.read_bytes() if path is not None and path.exists() else None
