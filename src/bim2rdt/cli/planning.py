"""`bim2rdt plan FILE` (the robot's map of a storey and a path through it) and `bim2rdt bench planning`."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

from bim2rdt.cli.common import console, out_path, print_json, print_table, sample_file, run_folder

BENCH_FILE = "Office_A_20110811.ifc"
_status = Console(stderr=True)


def register(app: typer.Typer, bench_app: typer.Typer) -> None:
    app.command("plan")(plan_command)
    bench_app.command("planning")(bench_planning_command)


def _point(text: str | None) -> tuple[float, float] | None:
    if text is None:
        return None
    try:
        x, y = (float(part) for part in text.split(","))
    except ValueError:
        raise typer.BadParameter(f"{text!r}: give a point as X,Y in metres, e.g. 1.5,2") from None
    return x, y


def plan_command(
    ifc_file: Path = typer.Argument(..., help="IFC file (IFC2X3, IFC4, IFC4X3)."),
    start: str | None = typer.Option(None, "--from", help="Start X,Y in metres (world frame of the model)."),
    goal: str | None = typer.Option(None, "--to", help="Goal X,Y in metres."),
    storey: str | None = typer.Option(None, "--storey", help="Storey name or GlobalId (default: the ground floor)."),
    resolution: float = typer.Option(0.05, "--resolution", help="Cell size, metres."),
    robot_radius: float = typer.Option(0.35, "--robot-radius", help="The robot's radius, metres."),
    doors: str = typer.Option("open", "--doors", help="'open', 'closed', or closed doors' names/GlobalIds, comma-separated."),
    off_limits: bool = typer.Option(True, "--off-limits/--no-off-limits", help="Keep out of zones tagged off-limits."),
    out: Path | None = typer.Option(None, "--out", parser=out_path, callback=lambda p: p and run_folder(p),
                                    help="Write the Nav2 map (map.pgm/.yaml, keep-out mask) and plan.png here."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON instead of text."),
) -> None:
    """Slice a storey into the robot's occupancy grid and, with --from/--to, plan a path through it."""
    from bim2rdt.bim import load_ifc
    from bim2rdt.config import get_settings, ifc_cache_dir
    from bim2rdt.planning import OccupancyGrid, path_length, plan_path

    model = load_ifc(ifc_file, cache_dir=ifc_cache_dir(get_settings()))
    policy = doors if doors in ("open", "closed") else [name.strip() for name in doors.split(",") if name.strip()]
    grid = OccupancyGrid.from_bim(model, storey=storey, resolution=resolution, robot_radius=robot_radius, doors=policy)
    if off_limits:
        grid = grid.with_zones(model.zones)
    path = None
    if (start is None) != (goal is None):
        raise typer.BadParameter("give both --from and --to, or neither")
    if start is not None:
        path = plan_path(grid, _point(start), _point(goal))
    written = _write_outputs(grid, path, out) if out is not None else {}
    payload = {"storey": grid.storey, "floor_z_m": grid.floor_z, "floor_from": grid.floor_source,
               "cells": list(grid.frame.shape), "resolution_m": grid.resolution, "open_doors": list(grid.open_doors),
               "keep_out": [fp.name for fp in grid.zones],
               "path": None if path is None else path.round(3).tolist(),
               "length_m": None if path is None else round(path_length(path), 3),
               "files": {k: str(v) for k, v in written.items()}}
    if as_json:
        print_json(payload)
        return
    console.print(f"storey {grid.storey!r}: floor at {grid.floor_z:.3f} m (from its {grid.floor_source}), "
                  f"{grid.frame.shape[0]} x {grid.frame.shape[1]} cells of {grid.resolution:g} m, "
                  f"{len(grid.open_doors)} open doors, keep-out: {', '.join(payload['keep_out']) or 'none'}")
    if path is not None:
        print_table(f"path: {payload['length_m']} m", ["x (m)", "y (m)"], [tuple(p) for p in payload["path"]])
    for what, where in written.items():
        console.print(f"wrote {what}: {where}")


def _write_outputs(grid, path, out: Path) -> dict[str, Path]:
    from bim2rdt.demo.plan_map import save_plan_map

    written = grid.save_nav2(out, "map")
    written["plot"] = save_plan_map(grid, out / "plan.png", paths=[path] if path is not None else [])
    return written


def bench_planning_command(
    ifc_file: Path | None = typer.Option(None, "--file", help=f"IFC file for the grid build (default: {BENCH_FILE} "
                                         "of the shared samples, BIM2RDT_SAMPLES)."),
    repeat: int = typer.Option(3, "--repeat", min=1, help="Interleaved runs of each contender; the best is kept."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON instead of a table."),
) -> None:
    """Grid build on a real office, plan_path vs bare pyastar2d on a 1000 x 1000 grid (target <= 1.2x), and
    replanning after one new obstacle vs rebuilding the grid, all in one run."""
    from rich.progress import Progress

    from bim2rdt.bench.planning import run_planning_bench

    path = ifc_file or sample_file(BENCH_FILE)
    with Progress(console=_status, transient=True, disable=not _status.is_terminal) as progress:
        task = progress.add_task("planning benchmark", total=5 * repeat)
        result = run_planning_bench(path, repeat, step=lambda label: progress.update(task, advance=1, description=label))
    summary = result.to_dict()
    if as_json:
        print_json(summary)
        return
    t, c = result.times, result.cpu
    rows = [("grid build: OccupancyGrid.from_bim", result.file, t["grid_build"], c["grid_build"], "load_ifc, cold",
             c["load_cold"], f"{summary['grid_vs_cold_load']:.3f}", "", ""),
            ("", "", "", "", "one section as lines (floor)", c["section_floor"],
             f"{summary['grid_vs_section_floor']:.2f}", "", ""),
            ("path: plan_path", "1000 x 1000 maze", t["plan_path"], c["plan_path"], "pyastar2d.astar_path",
             c["pyastar2d"], f"{summary['path_ratio']:.3f}", f"<= {summary['path_target']}",
             "yes" if summary["path_ok"] else "NO"),
            ("replan: with_obstacles + plan_path", "one drum on the path", t["replan"], c["replan"],
             "rebuild grid + plan_path", c["rebuild_and_plan"], f"{summary['replan_vs_rebuild']:.3f}", "", "")]
    print_table(f"Planning benchmark (best of {repeat}; ratio: median over back-to-back pairs, CPU time)",
                ["ours", "on", "wall s", "CPU s", "peer", "peer CPU s", "ratio", "target", "met"], rows)
