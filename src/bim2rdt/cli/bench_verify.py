"""`bim2rdt bench verify`: verify's seconds per frame by stage, peak memory and frames per second against the
source's own rate, on office1, the grabber frames, the TUM frame and the demo's bag (see bim2rdt.bench.verify)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import typer

from bim2rdt.cli.common import console, out_path, print_json, print_table, run_folder


def register(app: typer.Typer, bench_app: typer.Typer) -> None:
    bench_app.command("verify")(bench_verify)


def bench_verify(
    sensors: Path = typer.Option(Path(os.environ.get("BIM2RDT_SENSORS", "../shared/data/sensors")), "--sensors",
                                 help="The real sensor data folder (pcl/office1.*, pcl/grabber, tum); default "
                                      "$BIM2RDT_SENSORS or ../shared/data/sensors."),
    repeat: int = typer.Option(4, "--repeat", min=2, help="The long bag case plays the demo's bag this many times "
                               "in a row: its peak memory against the bag's once shows whether memory stays flat."),
    bag_dir: Path | None = typer.Option(None, "--bag-dir", parser=out_path,
                                        help="Keep the demo's bag here and reuse it on the next run (default: "
                                             "made afresh in a temporary folder; making it runs the demo's day)."),
    cases: str | None = typer.Option(None, "--cases", help="Only these cases, comma-separated (office1, grabber, "
                                     "tum, bag, bag-xN)."),
    one_core: bool = typer.Option(True, "--one-core/--all-cores",
                                  help="Pin the process to one CPU: the per-frame targets are for one core."),
    out: Path = typer.Option(Path("out/bench/verify"), "--out", parser=out_path, callback=run_folder,
                             help="Folder for results.json."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON instead of tables."),
) -> None:
    """Verify each recording with timing hooks on its stages; print seconds per frame by stage, frames per second
    against the source's rate, peak memory, and the targets."""
    from bim2rdt.atomic import write_bytes_atomic
    from bim2rdt.bench.verify import run_bench

    if one_core and hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    wanted = tuple(c.strip() for c in cases.split(",") if c.strip()) if cases else None
    record = run_bench(sensors, repeat, bag_dir, wanted, make_bag=_demo_bag)
    write_bytes_atomic(out / "results.json", json.dumps(record, indent=2).encode("utf-8"))
    if as_json:
        print_json(record)
        return
    show(record)
    console.print(f"results.json in {out}")


def _demo_bag(folder: Path) -> None:
    """Record the demo's day (a station per site object, a 2-minute safety shift) as a bag in ``folder``."""
    from bim2rdt.demo.site_day import run_site_day

    day = run_site_day(folder, workers=1, minutes=2.0, record=folder / "run.mcap")
    day.twin.close()


def show(record: dict) -> None:
    """The stage table (CPU seconds per frame), the rates and memory, and the targets."""
    from bim2rdt.bench.verify import FRAME_STAGES, RUN_STAGES

    rows, failed = [], []
    for row in record["cases"]:
        if "error" in row:
            failed.append((row["case"], row["error"]))
            continue
        cpu = row["cpu_s_per_frame"]
        rows.append((row["case"], row["frames"], row["localized"], *[f"{cpu[s]:.3f}" for s in FRAME_STAGES],
                     f"{row['cpu_s_per_frame_total']:.3f}", *[f"{cpu[s]:.3f}" for s in RUN_STAGES],
                     "-" if row["fps"] is None else f"{row['fps']:.2f}",
                     "-" if row["source_hz"] is None else f"{row['source_hz']:.1f}",
                     f"{row['peak_mb']:.0f}",
                     "-" if row["passed"] is None else f"{'PASS' if row['passed'] else 'FAIL'} <= {row['target_s']} s"))
    print_table("verify: CPU seconds per frame by stage, one core (per-run stages divided by the frames)",
                ["case", "frames", "fixed", *FRAME_STAGES, "per frame", *RUN_STAGES, "fps", "source Hz", "peak MB",
                 "target"], rows)
    memory = record.get("memory")
    if memory:
        console.print(f"memory: {memory['small']} ({memory['small_frames']} frames) {memory['small_peak_mb']:.0f} MB"
                      f" -> {memory['large']} ({memory['large_frames']} frames) {memory['large_peak_mb']:.0f} MB: "
                      f"x{memory['ratio']:.2f} ({'PASS' if memory['passed'] else 'FAIL'}, flat = at most "
                      f"x{record['targets']['memory_growth']})")
    for name, error in failed:
        console.print(f"[red]{name}: {error}[/red]")
    console.print(f"load average {record['load_average']} (CPU seconds are judged: the time this process ran)")
