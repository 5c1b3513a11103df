"""`bim2rdt bench perception`: the geometric detector against the ideal one (renderer masks) on the mission's
frames of seeded realities, YOLOE's time per frame when installed, and the flying-pixel study on S1."""

from __future__ import annotations

import json
import logging
import os
import tempfile
from pathlib import Path

import typer

from bim2rdt.cli.common import console, print_json, print_table, writable_folder


def register(app: typer.Typer, bench_app: typer.Typer) -> None:
    bench_app.command("perception")(bench_perception)


def bench_perception(
    seeds: int = typer.Option(5, "--seeds", min=0, help="Seeded realities of the embedded site (10 frames each; 0: "
                              "only the real office frame)."),
    seed: int = typer.Option(0, "--seed", min=0, help="First seed."),
    workers: float = typer.Option(0.3, "--workers", min=0.0, max=1.0,
                                  help="Fraction of frames a worker walks through."),
    flying_trials: int = typer.Option(20, "--flying-trials", min=0,
                                      help="S1 trials per flying-pixel condition (0 = skip the study)."),
    yoloe_weights: Path | None = typer.Option(None, "--yoloe-weights", help="Local YOLOE .pt (scored if given)."),
    yoloe_embeddings: Path | None = typer.Option(None, "--yoloe-embeddings",
                                                 help="Local .npz prompt embeddings for --yoloe-weights."),
    sensors: Path | None = typer.Option(None, "--sensors", envvar="BIM2RDT_SENSORS",
                                        help="The real sensor data folder (pcl/office1.*): scores the real office "
                                             "frame too (default: $BIM2RDT_SENSORS; skipped when absent)."),
    one_core: bool = typer.Option(True, "--one-core/--all-cores", help="Pin the process to one CPU."),
    out: Path = typer.Option(Path("out/bench/perception"), "--out", callback=writable_folder,
                              help="Folder for results.json."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON instead of tables."),
) -> None:
    """Detection precision/recall (objects >= 30 % visible), family accuracy, pose error and time per frame
    by stage, for the geometric detector and the ideal one in the same run; PASS/FAIL per target."""
    from bim2rdt.bench.perception.report import run_bench

    if (yoloe_weights is None) != (yoloe_embeddings is None):
        raise typer.BadParameter("--yoloe-weights and --yoloe-embeddings go together")
    if one_core and hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    logging.getLogger("bim2rdt.perception").setLevel(logging.ERROR)  # dropped detections are scored, not shown
    from bim2rdt.cli.registration import progress

    record: dict = {}
    if seeds > 0:
        with tempfile.TemporaryDirectory() as scratch, progress(seeds * 10, "perception frames") as tick:
            record = run_bench(Path(scratch), list(range(seed, seed + seeds)), workers, flying_trials,
                               (yoloe_weights, yoloe_embeddings) if yoloe_weights else None, tick)
    if sensors is not None:
        from bim2rdt.bench.perception.office import office_bench

        record["office"] = office_bench(sensors)
    (out / "results.json").write_text(json.dumps(record, indent=2, default=float))
    if as_json:
        print_json(record)
        return
    show(record)
    console.print(f"results.json in {out}")


def show(record: dict) -> None:
    if record.get("office"):
        show_office(record["office"])
    if "detectors" not in record:
        return
    rows = []
    for s in record["detectors"]:
        stages = ", ".join(f"{k} {1000 * v:.0f}" for k, v in s["stage_seconds_median"].items())
        rows.append((s["detector"], s["frames"], s["objects"], f"{s['recall']:.3f}", f"{s['precision']:.3f}",
                     f"{s['family_accuracy']:.3f}", f"{s['workers_unknown']}/{s['workers_seen']}",
                     f"{100 * s['translation_m_median']:.2f}", f"{s['tilt_deg_median']:.2f}",
                     f"{s['yaw_deg_median']:.2f}", f"{1000 * s['seconds_per_frame_median']:.0f}", stages))
    print_table("Perception on the mission's frames (objects >= 30 % visible; pose errors are medians)",
                ("detector", "frames", "objects", "recall", "precision", "family acc", "workers unknown",
                 "trans cm", "tilt °", "yaw °", "ms/frame", "ms by stage"), rows)
    if record.get("yoloe"):
        y = record["yoloe"]
        console.print(f"YOLOE ({y['weights']}): {1000 * y['seconds_per_frame_median']:.0f} ms per frame "
                      f"(median of {y['frames']}), {y['note']}")
    if record.get("flying"):
        print_table("Flying pixels on S1 (SG-ICP; Hausdorff RMSE over all registrations)",
                    ("depth", "mean m", "median m", "p90 m", "success", "registrations"),
                    [(row["condition"], f"{row['rmse_mean']:.4f}", f"{row['rmse_median']:.4f}",
                      f"{row['rmse_p90']:.4f}", f"{row['success']:.0%}", row["registrations"])
                     for row in record["flying"]])
    print_table("Targets (geometric detector, one core; the machine may be shared: read time against the ideal "
                f"pipeline's {1000 * record['ideal_seconds_per_frame']:.0f} ms in the same run)",
                ("target", "result", "detail"),
                [(name, "PASS" if passed else "FAIL", detail) for name, passed, detail in record["targets"]])


def show_office(office: dict) -> None:
    """The real office frame: recall and precision against the as-built IFC's furniture, for both pipelines."""
    print_table(f"Real frame: {office['frame']}, {office['boxes']} furniture boxes (found: within 5 cm of the "
                f"as-built IFC); verify's fix {100 * (office['localization_error_m'] or float('nan')):.1f} cm / "
                f"{office['localization_error_deg'] or float('nan'):.2f} deg from the truth",
                ("pipeline", "recall", "precision", "claims", "new", "trans cm (median)", "CPU s/frame"),
                [(p["pipeline"], f"{p['recall']:.2f}", f"{p['precision']:.2f}", p["claims"], p["new"],
                  "-" if p["translation_m_median"] is None else f"{100 * p['translation_m_median']:.1f}",
                  f"{p['cpu_seconds']:.2f}") for p in office["pipelines"]])
