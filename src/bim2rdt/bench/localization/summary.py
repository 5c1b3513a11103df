"""The tour's figures: errors against distance walked for dead reckoning, BIM fixes, the fused estimate and the
peers, time per frame, check shots, and the issue's targets with PASS/FAIL."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

import numpy as np

from bim2rdt.evaluation.checks import TargetCheck
from bim2rdt.bench.localization.run import LocalizationRun

BIM_MEDIAN_POSITION = 0.02
BIM_MEDIAN_YAW_DEG = 0.3
FUSED_WORST_POSITION = 0.05
SECONDS_PER_FRAME = 0.3
LOCKED = 0.1
"""A fix more than 10 cm off counts as locked onto the wrong surface (a wall's back face is 15-30 cm away)."""


def _median(values) -> float:
    values = [v for v in values if v is not None]
    return float(np.median(values)) if values else float("nan")


def summarize(run: LocalizationRun) -> dict:
    """Figures over the tour (lengths m, angles deg, times s)."""
    stations = run.stations
    fixes = [s for s in stations if s.fix is not None]
    last = stations[-1]
    summary = {
        "stations": len(stations), "walked": last.walked,
        "dead_reckoning": {"final_position": last.dead_reckoning.position, "final_yaw_deg": last.dead_reckoning.yaw_deg,
                           "worst_position": max(s.dead_reckoning.position for s in stations)},
        "bim": {"fixes": len(fixes), "refused": len(stations) - len(fixes),
                "degenerate": sum(1 for s in fixes if s.degenerate),
                "median_position": _median([s.fix.position for s in fixes]),
                "median_horizontal": _median([s.fix.horizontal for s in fixes]),
                "median_abs_height": _median([abs(s.fix.height) for s in fixes]),
                "median_yaw_deg": _median([abs(s.fix.yaw_deg) for s in fixes]),
                "median_position_constrained": _median([s.fix_across for s in fixes]),
                "worst_position_constrained": max((s.fix_across for s in fixes), default=float("nan")),
                "frames": sum(len(s.frame_seconds) for s in stations),
                "median_seconds": _median([t for s in stations for t in s.frame_seconds]),
                "worst_seconds": max(t for s in stations for t in s.frame_seconds)},
        "fused": {"worst_position": max(s.fused.position for s in stations),
                  "worst_position_first_look": max(s.fused_first_look.position for s in stations),
                  "looked_around": sum(1 for s in stations if s.looks > 1),
                  "median_position": _median([s.fused.position for s in stations]),
                  "worst_yaw_deg": max(abs(s.fused.yaw_deg) for s in stations),
                  "final_position": last.fused.position},
        "check_shots": {"stations_checked": sum(1 for s in stations if s.check_shots),
                        "flagged": [s.index for s in stations if s.check_flagged],
                        "median_residual": _median([s.check_residual for s in stations if s.check_shots])},
        "peers": {name: _peer(stations, name) for name in run.peers},
    }
    return summary


def _peer(stations, name: str) -> dict:
    errors = [s.peers[name][0] for s in stations]
    return {"median_position": _median([e.position for e in errors]),
            "median_yaw_deg": _median([abs(e.yaw_deg) for e in errors]),
            "worst_position": max(e.position for e in errors),
            "locked": sum(1 for e in errors if e.position > LOCKED),
            "median_seconds": _median([s.peers[name][1] for s in stations])}


def targets(summary: dict) -> list[TargetCheck]:
    """The issue's targets after the tour, each with the figure that decides it."""
    bim, fused = summary["bim"], summary["fused"]
    walked = f"after {summary['walked']:.0f} m"
    out = [
        TargetCheck("BIM-anchored median position <= 2 cm", bim["median_position"] <= BIM_MEDIAN_POSITION,
                   f"{bim['median_position'] * 100:.2f} cm over {bim['fixes']} fixes {walked}"),
        TargetCheck("BIM-anchored median yaw <= 0.3 deg", bim["median_yaw_deg"] <= BIM_MEDIAN_YAW_DEG,
                   f"{bim['median_yaw_deg']:.3f} deg"),
        TargetCheck("fused worst station <= 5 cm", fused["worst_position"] <= FUSED_WORST_POSITION,
                   f"{fused['worst_position'] * 100:.2f} cm {walked}"),
        TargetCheck("<= 0.3 s per frame on one core", bim["worst_seconds"] <= SECONDS_PER_FRAME,
                   f"every frame: worst {bim['worst_seconds']:.3f} s, median {bim['median_seconds']:.3f} s CPU over "
                   f"{bim['frames']} frames"),
    ]
    for name, peer in summary["peers"].items():
        out.append(TargetCheck(f"better than {name}", bim["median_position"] < peer["median_position"],
                               f"median {peer['median_position'] * 100:.2f} cm, {peer['locked']} stations > 10 cm off, "
                               f"{peer['median_seconds'] / max(bim['median_seconds'], 1e-9):.2f}x our time"))
    return out


def plot_errors(run: LocalizationRun, path: Path) -> Path:
    """Position and yaw error against distance walked: dead reckoning, prior, BIM fixes, fused, peers."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    stations = run.stations
    walked = [s.walked for s in stations]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
    series = [("dead reckoning", [s.dead_reckoning for s in stations], "-", "tab:red"),
              ("fused (odometry + BIM)", [s.fused for s in stations], "-", "tab:green")]
    for label, errors, style, colour in series:
        top.plot(walked, [e.position * 100 for e in errors], style, color=colour, label=label)
        bottom.plot(walked, [abs(e.yaw_deg) for e in errors], style, color=colour, label=label)
    fixed = [(s.walked, s.fix) for s in stations if s.fix is not None]
    top.plot([w for w, _ in fixed], [f.position * 100 for _, f in fixed], "o", color="tab:blue", label="BIM fix")
    bottom.plot([w for w, _ in fixed], [abs(f.yaw_deg) for _, f in fixed], "o", color="tab:blue", label="BIM fix")
    for name in run.peers:
        top.plot(walked, [s.peers[name][0].position * 100 for s in stations], "x", label=name)
        bottom.plot(walked, [abs(s.peers[name][0].yaw_deg) for s in stations], "x", label=name)
    top.set_yscale("symlog", linthresh=1.0)
    top.set_ylabel("camera position error (cm)")
    bottom.set_ylabel("|yaw error| (deg)")
    bottom.set_xlabel("distance walked (m)")
    top.axhline(5.0, color="grey", lw=0.5, ls="--")
    top.legend(fontsize=8)
    top.set_title(f"Localization on the embedded site, seed {run.seed}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def run_record(run: LocalizationRun) -> dict:
    """The run as plain JSON-able data: settings, every station, the summary and the targets."""
    summary = summarize(run)
    return {"seed": run.seed, "as_built_tolerance": run.tolerance, "config": run.config.model_dump(), "peers": run.peers,
            "summary": summary, "targets": [asdict(t) for t in targets(summary)],
            "stations": [asdict(station) for station in run.stations]}
