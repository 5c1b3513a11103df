"""The site day's localization in the report: each station's fix and check shots, and what the same mission gets
wrong on dead reckoning alone (objects it calls "moved" that never moved).

Verdicts are scored against the simulator's truth after the mission, per BIM element (what the twin records): a
verdict is right when a moved or knocked element is "deviating", an unchanged one "as planned", and a "new"
object stands where an unplanned one truly does; "false moved" is an unchanged element called deviating (moved),
the twin's costliest mistake (a crew sent to check, a path replanned around nothing).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from bim2rdt.demo.localized import MissionLocalization, ScoredStation  # noqa: E402
from bim2rdt.twin.status import ElementStatus  # noqa: E402

RIGHT = {(ElementStatus.DEVIATING, "moved"), (ElementStatus.DEVIATING, "knocked"),
         (ElementStatus.AS_PLANNED, "unchanged")}
"""(verdict, true change) pairs that are right for a BIM element."""


def verdict_tally(observations, truth, new_radius: float = 0.5) -> dict[str, int]:
    """Counts of right verdicts, false 'moved', missed changes, phantom 'new' and unverified fits. A verdict on a
    BIM element is judged against that element's true change (the observation's GlobalId, what the twin would
    record); a 'new' object is right when an unplanned one truly stands within ``new_radius`` m."""
    changes = {t.global_id: t.change for t in truth if t.global_id is not None}
    unplanned = np.array([t.T_world_model[:2, 3] for t in truth if t.global_id is None]).reshape(-1, 2)
    tally = dict.fromkeys(("right", "false moved", "missed change", "phantom new", "unverified"), 0)
    for obs in observations:
        status = ElementStatus(obs.status)
        if status == ElementStatus.UNVERIFIED:
            tally["unverified"] += 1
        elif obs.global_id is None:
            near = len(unplanned) and np.min(np.linalg.norm(unplanned - obs.pose[:2, 3], axis=1)) < new_radius
            tally["right" if near else "phantom new"] += 1
        elif (status, changes[obs.global_id]) in RIGHT:
            tally["right"] += 1
        else:
            tally["false moved" if status == ElementStatus.DEVIATING else "missed change"] += 1
    return tally


def station_rows(stations: list[ScoredStation]) -> list[dict]:
    """One row per station: how far the belief was from the truth, the looks and fixes, the check shots."""
    rows = []
    for s in stations:
        fixes = [look.fix for look in s.looks if look.applied]
        first = s.looks[0] if s.looks else None
        rows.append({
            "station": s.index, "planned_xy": s.planned[:2, 3].round(2).tolist(), "error_m": s.error,
            "looks": len(s.looks), "fixes": len(fixes),
            "residual_m": fixes[-1].residual if fixes else None,
            "free_directions": [np.round(d, 2).tolist() for d in first.fix.degenerate] if first and first.fix else [],
            "refused": first.reason if first and not first.applied else None,
            "check_residual_m": None if not s.check.shots else s.check.residual, "check_flagged": s.check.flagged,
            "check_shots": [{"landmark": shot.landmark.name, "residual_m": shot.residual, "tape_m": shot.tape}
                            for shot in s.check.shots]})
    return rows


def localization_record(localization: MissionLocalization, mission, truth) -> dict:
    """The JSON record: both runs' stations and verdict tallies."""
    return {"anchored": {"stations": station_rows(localization.stations),
                         "verdicts": verdict_tally(mission.observations, truth)},
            "dead_reckoning": {"stations": station_rows(localization.dead_reckoning_stations),
                               "verdicts": verdict_tally(localization.dead_reckoning.observations, truth)}}


def localization_markdown(record: dict) -> str:
    """The report's localization sections (Markdown)."""
    anchored, dead = record["anchored"], record["dead_reckoning"]
    lines = ["## Robot localization: odometry + BIM fixes", "",
             "The robot drives on legged odometry (drifting 2 % of the distance and 1° per 10 m) and fixes its pose at "
             "each station on the BIM's walls, columns and slab; where one view leaves a direction free it looks "
             "around. Error = believed vs true camera position (scored by the simulator afterwards).", "",
             "| station | planned (x, y) m | error cm | looks | fit residual mm | free directions | check shot cm |",
             "|---|---|---|---|---|---|---|"]
    for r in anchored["stations"]:
        residual = "-" if r["residual_m"] is None else f"{r['residual_m'] * 1000:.1f}"
        check = "-" if r["check_residual_m"] is None else \
            f"{r['check_residual_m'] * 100:.2f}{' **FLAG**' if r['check_flagged'] else ''}"
        lines.append(f"| {r['station']} | {r['planned_xy']} | {r['error_m'] * 100:.2f} | {r['looks']} | {residual} | "
                     f"{r['free_directions'] or '-'} | {check} |")
    lines += ["", "### Check shots (tape from the camera to the landmark; flagged above 3 cm)", ""]
    for r in anchored["stations"]:
        for shot in r["check_shots"]:
            lines.append(f"- station {r['station']}: {shot['landmark']}: tape {shot['tape_m']:.2f} m, residual "
                         f"{shot['residual_m'] * 100:.2f} cm")
    flagged = [r["station"] for r in anchored["stations"] if r["check_flagged"]]
    lines += ["", f"Stations flagged: {flagged or 'none'}.", "",
              "## The same mission on dead reckoning alone", "",
              "| run | right | false moved | missed change | phantom new | unverified | worst station error cm |",
              "|---|---|---|---|---|---|---|"]
    for name, run in (("odometry + BIM fixes", anchored), ("dead reckoning", dead)):
        tally = run["verdicts"]
        worst = max((r["error_m"] for r in run["stations"]), default=float("nan"))
        lines.append(f"| {name} | {tally['right']} | {tally['false moved']} | {tally['missed change']} | "
                     f"{tally['phantom new']} | {tally['unverified']} | {worst * 100:.1f} |")
    lines += ["", f"On dead reckoning the twin would report {dead['verdicts']['false moved']} object(s) as moved "
              "that never moved.", "", "![localization](localization.png)", ""]
    return "\n".join(lines)


def plot_localization(record: dict, path: Path) -> Path:
    """Believed-vs-true camera position error per station, both runs."""
    fig, ax = plt.subplots(figsize=(8, 3.5))
    for name, key, style in (("odometry + BIM fixes", "anchored", "o-"), ("dead reckoning", "dead_reckoning", "s-")):
        rows = record[key]["stations"]
        ax.plot([r["station"] for r in rows], [r["error_m"] * 100 for r in rows], style, label=name)
    ax.axhline(5.0, color="tab:orange", ls="--", lw=0.8, label="5 cm: 'moved' threshold")
    ax.set(xlabel="station", ylabel="camera position error (cm)", title="Where the robot believed it was")
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def localization_tables(record: dict) -> list[tuple[str, tuple[str, ...], list[tuple]]]:
    """(title, columns, rows) for the terminal: the stations with BIM fixes, and both runs' verdicts."""
    stations = [(r["station"], f"{r['error_m'] * 100:.2f}", r["looks"], len(r["free_directions"]) or "",
                 "-" if r["check_residual_m"] is None else
                 f"{r['check_residual_m'] * 100:.2f}{' FLAG' if r['check_flagged'] else ''}")
                for r in record["anchored"]["stations"]]
    verdicts = [(name, *record[key]["verdicts"].values(),
                 f"{max(r['error_m'] for r in record[key]['stations']) * 100:.1f}")
                for name, key in (("odometry + BIM fixes", "anchored"), ("dead reckoning", "dead_reckoning"))]
    return [("Robot localization: odometry + BIM fixes per station",
             ("station", "error cm", "looks", "free dirs", "check shot cm"), stations),
            ("Verdicts against the truth: BIM-anchored vs dead reckoning",
             ("run", "right", "false moved", "missed change", "phantom new", "unverified", "worst error cm"),
             verdicts)]
