"""`bim2rdt demo`: the main job on the embedded default site (for now, the registration scenarios)."""

from __future__ import annotations

from pathlib import Path

import typer

from bim2rdt.cli.common import console


def register(app: typer.Typer, bench_app: typer.Typer) -> None:
    app.command("demo")(demo_command)


def demo_command(
    out: Path = typer.Option(Path("out/demo"), "--out", help="Folder for plots, results.json and config.json."),
    trials: int = typer.Option(6, "--trials", min=1, help="Seeded trials per scenario."),
) -> None:
    """Register the BIM objects of four simulated site views with ICP and SG-ICP; print the paper's table and
    save plots, results and the resolved config beside them."""
    from bim2rdt.cli.registration import progress, show_run
    from bim2rdt.demo import run_demo

    with progress(4 * trials, "registration scenarios") as tick:
        run = run_demo(out, trials=trials, tick=tick)
    show_run(run)
    console.print(f"plots, results.json and config.json in {out}")
