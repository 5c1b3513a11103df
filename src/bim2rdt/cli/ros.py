"""`bim2rdt bench ingest`: ROS bag reading speed against bare rosbags, the verify chain per frame, memory."""

from __future__ import annotations

import tempfile
from pathlib import Path

import typer

from bim2rdt.cli.common import console, print_json, print_table


def register(app: typer.Typer, bench_app: typer.Typer) -> None:
    bench_app.command("ingest")(bench_ingest)


def bench_ingest(
    bag: Path | None = typer.Option(None, "--bag", exists=True, help="A recorded bag (e.g. demo --record); default: "
                                    "one written in the recorder's format."),
    ifc: Path | None = typer.Option(None, "--ifc", exists=True, dir_okay=False,
                                    help="The bag's IFC: adds the verify chain per frame."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document instead of the table."),
) -> None:
    """Frames/s decoding a bag (ours vs bare rosbags over the same messages, target <= 1.2x the bare time), the
    verify chain per frame, and peak RSS streaming a 10- vs a 40-station bag (subprocesses; target flat)."""
    from bim2rdt.bench.ingest import run_bench

    with tempfile.TemporaryDirectory(prefix="bench-ingest-") as folder:
        with console.status("bench ingest: writing bags, reading them"):
            result = run_bench(Path(folder), bag, ifc)
    if as_json:
        print_json(result)
        return
    decode, memory = result["decode"], result["memory"]
    rows = [("decode (open_source)", f"{decode['ours_fps']:.1f} frames/s", f"bare rosbags {decode['bare_fps']:.1f} "
             f"frames/s", f"{decode['ratio']:.2f}x", f"<= {decode['target']}x",
             "ok" if decode["ratio"] <= decode["target"] else "MISSED"),
            ("decode, CPU time", "", "bare rosbags", f"{decode['cpu_ratio']:.2f}x", f"<= {decode['target']}x",
             "ok" if decode["cpu_ratio"] <= decode["target"] else "MISSED"),
            ("peak RSS 10 -> 40 stations", f"{memory['peak_rss_mb'][0]} -> {memory['peak_rss_mb'][1]} MB", "",
             f"{memory['ratio']:.2f}x", f"<= {memory['target']}x", "ok" if memory["ratio"] <= memory["target"]
             else "MISSED")]
    if "verify" in result:
        verify = result["verify"]
        rows.append(("verify chain", f"{verify['seconds_per_frame']:.2f} s/frame",
                     f"{verify['localized']}/{verify['frames']} localized", "", "", ""))
    print_table(f"bench ingest ({decode['frames']} frames)", ("what", "ours", "peer", "ratio", "target", ""), rows)
