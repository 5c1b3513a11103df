"""The site day's report: a plan view of the site (BIM vs measured vs true poses, robot stations), the workers'
A(8) through the day against EAV/ELV, a JSON record and a Markdown summary."""

from __future__ import annotations

import json
from datetime import datetime, timezone
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from bim2rdt.atomic import write_bytes_atomic  # noqa: E402
from bim2rdt.safety import EAV, ELV  # noqa: E402
from bim2rdt.demo.localization_report import (localization_markdown, localization_record,  # noqa: E402
                                              plot_localization)
from bim2rdt.demo.plan_map import outline  # noqa: E402
from bim2rdt.demo.routes import draw_walk, route_markdown, write_route_files  # noqa: E402
from bim2rdt.sim.reality import objects_of_interest  # noqa: E402
from bim2rdt.demo.site_day import SiteDay  # noqa: E402
from bim2rdt.sim.meshes import mesh_for_family  # noqa: E402
from bim2rdt.sim.reality import TrueObject  # noqa: E402
from bim2rdt.sim.truth import match_truth, pose_error  # noqa: E402
from bim2rdt.twin import ElementStatus  # noqa: E402

STATUS_COLOURS = {ElementStatus.AS_PLANNED: "tab:green", ElementStatus.DEVIATING: "tab:orange",
                  ElementStatus.NEW: "tab:red", ElementStatus.UNVERIFIED: "tab:grey",
                  ElementStatus.MISSING: "tab:purple"}
OBSERVATION_COLUMNS = ("object", "verdict", "truth", "bias", "shift m", "yaw °", "tilt °", "fitness", "err cm",
                       "err °")
"""Headers of :func:`observation_cells`, shared by the terminal table and report.md."""


def true_objects(day: SiteDay) -> list[TrueObject | None]:
    """The simulated truth behind each observation, found by geometry after the mission (None: a phantom)."""
    matches = match_truth([(obs.family, obs.pose) for obs in day.mission.observations],
                          [(t.family, t.T_world_model) for t in day.reality.truth])
    return [None if index is None else day.reality.truth[index] for index in matches]


def observation_rows(day: SiteDay) -> list[dict]:
    """One row per registered object: verdict, deltas against the BIM, fit, and the error against the truth."""
    rows = []
    for obs, truth in zip(day.mission.observations, true_objects(day)):
        error = (pose_error(obs.family, obs.pose, truth.T_world_model, day.priors[obs.family].symmetry)
                 if truth else None)
        rows.append({
            "family": obs.family, "label": day.priors[obs.family].label, "global_id": obs.global_id,
            "status": obs.status.value, "reason": obs.reason, "truth": truth.change if truth else None,
            "upright_bias": obs.upright_bias,
            "shift_m": obs.shift, "yaw_deg": obs.yaw_deg, "tilt_deg": obs.tilt_deg, "points": obs.points,
            "fitness": obs.fitness, "rmse_m": obs.rmse, "frames": list(obs.frames),
            "error_rotation_deg": error.rotation_deg if error else None,
            "error_translation_m": error.translation if error else None,
            "error_tilt_deg": error.tilt_deg if error else None})
    return rows + [missing_row(day, gone) for gone in day.mission.missing]


def missing_row(day: SiteDay, gone) -> dict:
    """The row of an element whose place the robot saw empty: no pose, no fit; the evidence (station, frames,
    share of its place seen through) and what the simulated truth says (``removed``, or a false alarm)."""
    return {"family": gone.family, "label": day.priors[gone.family].label if gone.family in day.priors else gone.family,
            "global_id": gone.global_id, "status": ElementStatus.MISSING.value,
            "truth": missing_truth(day, gone.global_id), "upright_bias": None, "shift_m": None, "yaw_deg": None,
            "tilt_deg": None, "points": gone.cells, "fitness": None, "rmse_m": None, "frames": list(gone.frames),
            "station": gone.station, "see_through": gone.see_through, "error_rotation_deg": None,
            "error_translation_m": None, "error_tilt_deg": None}


def set_aside_row(obs) -> dict:
    """A detection the mission set aside (its fit shows a known surface, not an object): family, station, points
    and why."""
    return {"family": obs.family, "station": obs.station, "points": obs.points, "fitness": obs.fitness,
            "reason": obs.reason}


def set_aside_line(day: SiteDay) -> str:
    """One sentence on the detections set aside, for the terminal and report.md."""
    if not day.mission.set_aside:
        return "Set aside: none."
    return "Set aside (no object; the points show a known surface): " + "; ".join(
        f"{day.priors[obs.family].label if obs.family in day.priors else obs.family} at station {obs.station} "
        f"{obs.reason}" for obs in day.mission.set_aside) + "."


def missing_truth(day: SiteDay, global_id: str) -> str | None:
    """Scoring after the mission: what the simulated truth did to an element reported missing ("removed", or
    its other change: a false alarm)."""
    return next((t.change for t in [*day.reality.removed, *day.reality.truth] if t.global_id == global_id), None)


def observation_cells(row: dict) -> tuple[str, ...]:
    """One row of :func:`observation_rows` as table cells (see :data:`OBSERVATION_COLUMNS`); truth and errors
    are '-' for an object with no simulated truth to score against (a real robot's observations), pose and fit
    '-' for a missing element (nothing was there to fit)."""
    def number(value, digits: int, scale: float = 1.0) -> str:
        return "-" if value is None else f"{scale * value:.{digits}f}"

    status = f"{row['status']} {row['reason']}" if row.get("reason") else row["status"]
    return (row["label"], status, row["truth"] or "-", number(row["upright_bias"], 2),
            number(row["shift_m"], 2), number(row["yaw_deg"], 1), number(row["tilt_deg"], 1),
            number(row["fitness"], 2), number(row["error_translation_m"], 1, 100.0),
            number(row["error_rotation_deg"], 1))


def write_site_report(day: SiteDay, out_dir: Path) -> dict[str, Path]:
    """Write plan.png, exposure.png, site_day.json and report.md into ``out_dir``, and with a planned route the
    plan map and the Nav2 map (:func:`bim2rdt.demo.routes.write_route_files`); returns their paths."""
    rows = observation_rows(day)
    paths = {"plan": plot_plan(day, out_dir / "plan.png"), "exposure": plot_exposure(day, out_dir / "exposure.png")}
    record = {"twin": str(day.twin_path), "observations": rows, "not_seen": day.mission.not_seen,
              "set_aside": [set_aside_row(obs) for obs in day.mission.set_aside],
              "hav_events": [_event_row(e) for e in day.hav_events if not e.kind.endswith("predicted")],
              "twin_records": day.twin_records, "route": day.route.summary() if day.route else None}
    if day.route is not None:
        paths.update(write_route_files(day, out_dir))
    localization = ""
    if day.localization is not None:
        record["localization"] = localization_record(day.localization, day.mission, day.reality.truth)
        paths["localization"] = plot_localization(record["localization"], out_dir / "localization.png")
        localization = localization_markdown(record["localization"])
    paths["json"] = out_dir / "site_day.json"
    write_bytes_atomic(paths["json"], json.dumps(record, indent=2, default=float).encode("utf-8"))
    paths["report"] = out_dir / "report.md"
    write_bytes_atomic(paths["report"], (_markdown(day, rows, record) + localization).encode("utf-8"))
    return paths


def plot_plan(day: SiteDay, path: Path) -> Path:
    """Plan view: BIM footprints (dashed), measured ones (filled by verdict), true centres (x), stations."""
    fig, ax = plt.subplots(figsize=(10, 7))
    for el in day.model.elements:
        if el.ifc_class in ("IfcWall", "IfcWallStandardCase", "IfcColumn") and day.model.has_mesh(el.global_id):
            vertices, _ = day.model.mesh(el.global_id)
            ax.fill(*outline(vertices[:, :2]).T, color="0.8", zorder=0)
    targets = {t.global_id: t for t in objects_of_interest(day.model)}
    for obs, truth in zip(day.mission.observations, true_objects(day)):
        _draw_observation(ax, obs, targets.get(obs.global_id), truth)
    for gone in day.mission.missing:
        target = targets[gone.global_id]
        ax.fill(*_footprint(target.mesh_body.vertices, target.placement).T, color=STATUS_COLOURS[ElementStatus.MISSING],
                alpha=0.35, hatch="xx")
    if day.route is not None:
        draw_walk(ax, day.route, day.mission.stations)
    else:
        stations = np.array([T[:3, 3] for T in day.mission.stations])
        ax.plot(stations[:, 0], stations[:, 1], "-o", color="tab:blue", ms=4, lw=1, label="robot stations")
    for status, colour in STATUS_COLOURS.items():
        ax.fill([], [], color=colour, alpha=0.7, label=status.value)
    ax.set(aspect="equal", xlabel="x (m)", ylabel="y (m)",
           title="Site plan: BIM (dashed) vs measured by SG-ICP (filled); x = true position")
    ax.legend(loc="upper right", fontsize=8)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def _draw_observation(ax, obs, target, truth: TrueObject | None) -> None:
    """One object on the plan: its BIM footprint (dashed, if planned), the measured one filled with the verdict's
    colour, and its true centre (x)."""
    if target is not None:
        bim = _footprint(target.mesh_body.vertices, target.placement)
        ax.plot(*np.vstack([bim, bim[:1]]).T, "--", color="0.3", lw=0.8)
    body = target.mesh_body.vertices if target is not None else mesh_for_family(obs.family).vertices
    ax.fill(*_footprint(body, obs.pose).T, color=STATUS_COLOURS[obs.status], alpha=0.7)
    if truth is not None:
        ax.plot(truth.T_world_model[0, 3], truth.T_world_model[1, 3], "kx", ms=6)


def plot_exposure(day: SiteDay, path: Path) -> Path:
    """Each worker's A(8) (m/s^2) through the shift, with the EAV and ELV lines."""
    fig, ax = plt.subplots(figsize=(9, 4))
    by_worker: dict[str, list[tuple[float, float]]] = {}
    for when, subject, a8 in day.exposure_timeline:
        by_worker.setdefault(subject, []).append((when, a8))
    for subject, series in by_worker.items():
        times, values = np.array(series).T
        ax.plot([datetime.fromtimestamp(t, timezone.utc) for t in times], values, label=f"worker {subject[:8]}")
    ax.axhline(EAV, color="tab:orange", ls="--", label="EAV 2.5 m/s²")
    ax.axhline(ELV, color="tab:red", ls="--", label="ELV 5 m/s²")
    ax.set(ylabel="A(8) (m/s²)", xlabel="time (UTC)", title="Daily hand-arm vibration exposure (ISO 5349-1)")
    ax.legend(fontsize=8)
    fig.autofmt_xdate()
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def _markdown(day: SiteDay, rows: list[dict], record: dict) -> str:
    twin = (f"Twin written to `{day.twin_path.name}` (as-designed model: `site.ifc`)." if day.twin_path else
            f"No IFC twin written: `site.ifc` is {day.model.schema}, which has no IfcEvent or IfcTaskTime; IFC "
            "write-back needs IFC4 (the twin lives in the history and BCF).")
    lines = ["# bim2rdt site day", "", twin, "",
             "## Objects verified by the robot", "",
             "| " + " | ".join(("family", *OBSERVATION_COLUMNS)) + " |", "|---" * (len(OBSERVATION_COLUMNS) + 1) + "|"]
    lines += ["| " + " | ".join((r["family"], *observation_cells(r))) + " |" for r in rows]
    lines += ["", f"Not seen: {', '.join(day.mission.not_seen) or 'none'}.", "", set_aside_line(day), ""]
    lines += route_markdown(day.route) if day.route is not None else []
    lines += ["## Safety events", "",
              "| time (UTC) | event | worker | A(8) m/s² |", "|---|---|---|---|"]
    for e in record["hav_events"]:
        lines.append(f"| {e['time']} | {e['kind']} | {e['subject'][:8]} | {e['a8']} |")
    lines += ["", f"IFC records written: {len(day.twin_records)} "
              f"({sum(c == 'IfcEvent' for c, _ in day.twin_records)} IfcEvent, "
              f"{sum(c == 'IfcTask' for c, _ in day.twin_records)} IfcTask).", "",
              "![plan](plan.png)", "", "![exposure](exposure.png)", ""]
    if getattr(day, "progress", None) is not None:
        from bim2rdt.demo.progress import progress_text

        lines.append(progress_text(day.progress))
    return "\n".join(lines)


def _event_row(event) -> dict:
    a8 = event.data.get("day_a8")
    return {"time": datetime.fromtimestamp(event.time, timezone.utc).strftime("%H:%M:%S"), "kind": event.kind,
            "subject": event.subject, "a8": round(float(a8), 2) if a8 is not None else None}


def _footprint(vertices_body: np.ndarray, T: np.ndarray) -> np.ndarray:
    world = np.asarray(vertices_body) @ T[:3, :3].T + T[:3, 3]
    return outline(world[:, :2])

