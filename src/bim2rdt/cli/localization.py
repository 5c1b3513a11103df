"""`bim2rdt bench localization`: a 100 m tour on drifting odometry; dead reckoning, BIM fixes and the fused
estimate against distance walked, time per frame, check shots, and Open3D's point-to-plane ICP as the peer; then
the real office frame (office1.pcd on office1.ifc) fixed from 20 priors around its truth: by the frame localizer
with and without its depth correction, and by the cloud localizer verify runs (corrected)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import typer

from bim2rdt.cli.common import console, print_json, print_table, run_folder


def register(app: typer.Typer, bench_app: typer.Typer) -> None:
    bench_app.command("localization")(bench_localization)


def bench_localization(
    distance: float = typer.Option(100.0, "--distance", min=5.0, help="Metres of tour to walk (laps of the "
                                                                       "embedded site's stations)."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the odometry drift, moved site objects and noise."),
    tolerance: float = typer.Option(0.01, "--tolerance", min=0.0, help="How far the built walls, columns and slab "
                                    "stand off the BIM (1 sigma per axis, m); 0 = built exactly as modelled."),
    out: Path = typer.Option(Path("out/bench/localization"), "--out", callback=run_folder,
                             help="Folder for the plot, results.json and the site it ran on."),
    peers: bool | None = typer.Option(None, "--peers/--no-peers",
                                      help="Run Open3D too (default: when open3d is importable)."),
    one_core: bool = typer.Option(True, "--one-core/--all-cores",
                                  help="Pin the process to one CPU: the per-frame target is for one core."),
    tour: bool = typer.Option(True, "--tour/--no-tour", help="Walk the simulated tour."),
    office: bool = typer.Option(True, "--office/--no-office",
                                help="Localize the real office frame too (skipped when the sensor data is absent)."),
    sensors: Path = typer.Option(Path(os.environ.get("BIM2RDT_SENSORS", "../shared/data/sensors")), "--sensors",
                                 help="The real sensor data folder (pcl/office1.pcd, office1.ifc, "
                                      "office1_truth.json); default $BIM2RDT_SENSORS or ../shared/data/sensors."),
    office_priors: int = typer.Option(20, "--office-priors", min=1, help="Priors to fix the office frame from "
                                      "(sampled within 30 cm and 8 deg of its truth)."),
    global_search: bool = typer.Option(True, "--global/--no-global", help="Search the tour's stations and the "
                                       "office frame with no prior too (and Open3D FPFH + RANSAC with --peers), "
                                       "each frame alone and the stations in order as one sweep on the robot's "
                                       "drifting odometry in an unaligned frame."),
    people: bool = typer.Option(True, "--people/--no-people", help="With --global and the tour: search frames that "
                                "look at the site's people alone, with and without free-standing things counted "
                                "whole, and count the wrong-and-confident ones."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON instead of tables."),
) -> None:
    """Walk the tour, localize every station on the BIM, fuse with odometry, and print errors and targets; then
    fix the real office frame from priors around its truth."""
    from bim2rdt.atomic import write_bytes_atomic
    from bim2rdt.bench.localization.peers import Open3dPointToPlane
    from bim2rdt.bench.localization.run import run_tour
    from bim2rdt.bench.localization.summary import plot_errors, run_record
    from bim2rdt.cli.registration import _open3d_available, step_progress
    from bim2rdt.config import get_settings
    from bim2rdt.sim.tour import tour_poses

    if one_core and hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    config = get_settings().localization
    record, plot = {}, None
    if tour:
        methods = [Open3dPointToPlane(config, visible_only=False), Open3dPointToPlane(config, visible_only=True)] \
            if (_open3d_available() if peers is None else peers) else []
        with step_progress(len(tour_poses(distance)), "localization tour") as tick:
            run = run_tour(out, seed, distance, config, methods, tick=tick, tolerance=tolerance)
        record = run_record(run)
        plot = plot_errors(run, out / "errors.png")
    if office:
        record["office"] = _office(sensors, config, seed, out, office_priors)
    if global_search and (tour or office):
        record["global"] = _global(out, seed, distance, peers, sensors if office else None, tour, people)
    write_bytes_atomic(out / "results.json", json.dumps(record, indent=2, default=float).encode("utf-8"))
    if as_json:
        print_json(record)
        return
    if tour:
        show_record(record)
    if office:
        show_office(record["office"])
    if "global" in record:
        show_global(record["global"])
    console.print(f"{f'plot {plot}, ' if plot else ''}results.json in {out}")


def _office(sensors: Path, config, seed: int, out: Path, count: int) -> dict:
    from bim2rdt.bench.localization.office import FRAME, run_office

    if not (sensors / FRAME).is_file():
        return {"skipped": f"no {FRAME} under {sensors} (set --sensors or BIM2RDT_SENSORS)"}
    return run_office(sensors, config, count, seed=seed, cache_dir=out / "cache")


def _global(out: Path, seed: int, distance: float, peers: bool | None, sensors: Path | None, tour: bool,
            people: bool = True) -> dict:
    from bim2rdt.bench.localization.global_bench import run_global
    from bim2rdt.cli.registration import _open3d_available, step_progress
    from bim2rdt.sim.tour import tour_poses

    peer = _open3d_available() if peers is None else peers
    with step_progress(len(tour_poses(distance)) if tour else 1, "global search") as tick:
        return run_global(out, seed, distance, peer=peer, sensors=sensors, tick=tick, tour=tour, people=people)


def show_global(record: dict) -> None:
    """No prior: success, wrong-and-confident and refused rates, time per search; ours and the peer's."""
    rows = []
    for name, label in (("ours", "find_pose, one frame"), ("look_around", "find_pose, looking 70 deg either way"),
                        ("sweep", "Sweep: the stations in order, places carried by drifting unaligned odometry"),
                        ("peer", "Open3D FPFH + RANSAC + ICP, one frame")):
        s = record["summary"].get(name)
        if s is None or not s["stations"]:
            continue
        rows.append((label, f"{s['success_rate']:.0%}", f"{s['wrong_and_confident_rate']:.0%}",
                     f"{s['refused_rate']:.0%}", f"{s['median_seconds']:.2f} / {s['max_seconds']:.2f}"))
    tolerance = record["tolerance"]
    print_table(f"No prior: {record['summary']['ours']['stations']} tour stations, success within "
                f"{tolerance['position_m'] * 100:.0f} cm and {tolerance['yaw_deg']:.0f} deg",
                ["method", "success", "wrong and confident", "refused", "s per search or station (median / max)"],
                rows)
    office = record.get("office")
    if office:
        for name, entry in (("find_pose", office["ours"]), ("FPFH + RANSAC", office.get("peer"))):
            if entry is None:
                continue
            detail = (f"{entry['position_m'] * 100:.1f} cm / {entry['yaw_deg']:.2f} deg" if "position_m" in entry
                      else entry.get("reason", ""))
            console.print(f"office1, no prior, {name}: {entry['outcome']} ({detail}), {entry['seconds']:.2f} s")
    people = record.get("people")
    if people:
        s = people["summary"]
        counts = {name: f"{s[name]['wrong']} wrong and confident, {s[name]['success']} right, "
                        f"{s[name]['refused']} refused" for name in ("with", "without")}
        console.print(f"People in view, one frame each: {s['person_in_view']} of {s['frames']} frames; free-standing "
                      f"things counted whole: {counts['with']}; every point on its own: {counts['without']}")


def show_office(office: dict) -> None:
    """The office frame's fixes per localizer and depth variant: accepted, errors, refusals, time."""
    if "skipped" in office:
        console.print(f"office frame skipped: {office['skipped']}")
        return
    rows = []
    rows_in = [(f"localize, {name}", variant) for name, variant in office["variants"].items()]
    if "cloud" in office:
        rows_in.append((f"localize_cloud, {office['cloud']['depth']}", office["cloud"]))
    for name, variant in rows_in:
        s = variant["summary"]
        error = "-" if not s["accepted"] else (f"median {s['median_position_cm']:.2f} cm / {s['median_yaw_deg']:.2f} "
                                               f"deg, worst {s['worst_position_cm']:.2f} cm / "
                                               f"{s['worst_yaw_deg']:.2f} deg")
        refusals = "; ".join(f"{count} {why}" for why, count in s["refusals"].items()) or "-"
        rows.append((name, f"{s['accepted']}/{office['priors']}", error, refusals, f"{s['median_seconds']:.3f}"))
    print_table(f"Real office frame ({office['frame']}): BIM fix from {office['priors']} priors within "
                f"{office['radius_m'] * 100:.0f} cm and {office['yaw_deg']:.0f} deg of the truth (median prior "
                f"{office['variants']['corrected']['summary']['median_prior_cm']:.1f} cm off)",
                ["localizer, depth", "fixed", "error (accepted)", "refused", "s per frame"], rows)


def show_record(record: dict) -> None:
    """Per-station errors against distance walked, the summary, and the targets."""
    names = record["peers"]
    rows = []
    for s in record["stations"]:
        fix = s["fix"]
        rows.append((s["index"], f"{s['walked']:.1f}", _cm(s["dead_reckoning"]), _cm(s["prior"]),
                     _cm(fix) if fix else f"refused: {s['reason'][:40]}" if s["reason"] else "-",
                     (s["degenerate"] or "") if s["looks"] == 1 else f"{s['degenerate'] or ''} +{s['looks'] - 1} look",
                     _cm(s["fused"]), f"{s['fix_seconds']:.3f}",
                     "-" if not s["check_shots"] else f"{s['check_residual'] * 100:.2f}{' FLAG' if s['check_flagged'] else ''}",
                     *[_cm(s["peers"][name][0]) for name in names]))
    print_table("Camera error (position cm / yaw deg) against distance walked",
                ["#", "walked m", "dead reckoning", "prior", "BIM fix", "free dirs", "fused", "frame s (slowest)",
                 "check shot cm", *names], rows)
    summary = record["summary"]
    bim, fused, dead = summary["bim"], summary["fused"], summary["dead_reckoning"]
    lines = [("dead reckoning", f"{dead['final_position'] * 100:.1f} cm / {dead['final_yaw_deg']:.2f} deg at the end",
              f"worst {dead['worst_position'] * 100:.1f} cm"),
             ("BIM fix", f"median {bim['median_position'] * 100:.2f} cm / {bim['median_yaw_deg']:.3f} deg "
                         f"(horizontal {bim['median_horizontal'] * 100:.2f} cm, height {bim['median_abs_height'] * 100:.2f} cm)",
              f"{bim['fixes']} fixes ({bim['degenerate']} degenerate), {bim['refused']} refused; across constrained "
              f"directions median {bim['median_position_constrained'] * 100:.2f} cm, worst "
              f"{bim['worst_position_constrained'] * 100:.2f} cm; {bim['median_seconds']:.3f} s per frame (worst "
              f"{bim['worst_seconds']:.3f} s)"),
             ("fused", f"worst {fused['worst_position'] * 100:.2f} cm, median {fused['median_position'] * 100:.2f} cm",
              f"worst yaw {fused['worst_yaw_deg']:.3f} deg; looked around at {fused['looked_around']} stations "
              f"(worst {fused['worst_position_first_look'] * 100:.2f} cm after the first look alone)"),
             ("check shots", f"{summary['check_shots']['stations_checked']} stations saw landmarks",
              f"flagged (> 3 cm): {summary['check_shots']['flagged'] or 'none'}")]
    for name, peer in summary["peers"].items():
        lines.append((name, f"median {peer['median_position'] * 100:.2f} cm / {peer['median_yaw_deg']:.3f} deg",
                      f"worst {_metres(peer['worst_position'])}, {peer['locked']} stations > 10 cm off, "
                      f"{peer['median_seconds']:.3f} s per frame"))
    print_table(f"Summary after {summary['walked']:.0f} m ({summary['stations']} stations, seed {record['seed']}, "
                f"building {record['as_built_tolerance'] * 100:.1f} cm off its BIM)",
                ["estimate", "error", "detail"], lines)
    print_table("Targets", ["target", "result", "detail"],
                [(t["name"], "PASS" if t["passed"] else "FAIL", t["detail"]) for t in record["targets"]])


def _cm(error: dict) -> str:
    if error["position"] > 10.0:
        return "lost (> 10 m)"
    return f"{error['position'] * 100:.2f} / {error['yaw_deg']:+.2f}"


def _metres(value: float) -> str:
    return "lost (> 10 m)" if value > 10.0 else f"{value * 100:.1f} cm"
