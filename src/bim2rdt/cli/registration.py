"""`bim2rdt bench registration`: the paper's Hausdorff table (ICP vs SG-ICP, four scenarios) with success rate,
tilt error and time per object, against Open3D's ICPs given the same restarts, and PASS/FAIL per target."""

from __future__ import annotations

import os
from pathlib import Path

import typer

from bim2rdt.cli.common import console, out_path, print_json, print_table, run_folder

PEER_COLUMNS = ("SG-ICP upright only", "Open3D pt-pt", "Open3D pt-plane", "small_gicp plane 1T",
                "small_gicp GICP 1T", "small_gicp plane allT", "small_gicp GICP allT")


def register(app: typer.Typer, bench_app: typer.Typer) -> None:
    bench_app.command("registration")(bench_registration)


def bench_registration(
    trials: int = typer.Option(50, "--trials", min=1, help="Seeded trials per scenario (3 objects each)."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of scenes, noise, corners and initial poses."),
    out: Path = typer.Option(Path("out/bench/registration"), "--out", parser=out_path, callback=run_folder,
                              help="Folder for plots and results.json."),
    peers: bool | None = typer.Option(None, "--peers/--no-peers",
                                      help="Run Open3D too (default: when open3d is importable)."),
    one_core: bool = typer.Option(True, "--one-core/--all-cores",
                                  help="Pin the process to one CPU so Open3D's TBB threads and our numpy "
                                       "compete on equal terms."),
    families: bool = typer.Option(True, "--families/--no-families",
                                  help="Also run the scene families F1-F11 (sparse half-occluded single views "
                                       "built outside S1-S4; F10-F11 are sparse yaw-alias views from two "
                                       "generators)."),
    scenarios: list[str] | None = typer.Option(
        None, "--scenario", help="Run only this scenario (S1-S4; repeat for more). Default: all four."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON instead of tables."),
) -> None:
    """Run S1-S4 with ICP, SG-ICP (priors from the knowledge base), Open3D and small_gicp, then the scene
    families F1-F11; print the tables and targets."""
    from bim2rdt.evaluation.runs import FAMILY_NAMES, run_registration_scenarios, run_record, save_run
    from bim2rdt.config import get_settings, settings_record
    from bim2rdt.sim.scenarios import SCENARIOS

    chosen = tuple(dict.fromkeys(scenarios)) if scenarios else tuple(SCENARIOS)
    unknown = [name for name in chosen if name not in SCENARIOS]
    if unknown:
        raise typer.BadParameter(f"unknown scenario {', '.join(unknown)}; choose from {', '.join(SCENARIOS)}",
                                 param_hint="'--scenario'")
    if one_core and hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    use_peers = _open3d_available() if peers is None else peers
    settings = get_settings()
    names = FAMILY_NAMES if families else ()
    with step_progress((len(chosen) + len(names)) * trials, "registration scenarios and families") as tick:
        run = run_registration_scenarios(out, trials, seed, settings.registration, use_peers, names=chosen,
                                         families=names, tick=tick)
    save_run(run, out, settings_record(settings))
    if as_json:
        print_json(run_record(run, settings_record(settings)))
        return
    show_run(run)
    console.print(f"plots and results.json in {out}")


def show_run(run, targets: bool = True) -> None:
    """Print the paper's table plus success/tilt/time per scenario, then (with ``targets``) the targets."""
    from bim2rdt.evaluation.stats import cut_interval, improvement

    peers = [name for name in PEER_COLUMNS if name in run.results[0].stats]
    rows = []
    for result in run.results:
        s = result.stats
        for label, key, scale in (("RMSE (m)", "rmse", 1.0), ("Mean (m)", "mean", 1.0), ("Max (m)", "max", 1.0)):
            icp, sg = getattr(s["ICP"], key), getattr(s["SG-ICP"], key)
            low, high = cut_interval(result, key)
            rows.append((result.name, label, f"{icp:.6f}", f"{sg:.6f}",
                         f"{improvement(icp, sg):+.1f} % [{low:+.0f}, {high:+.0f}]",
                         *[f"{getattr(s[p], key) * scale:.6f}" for p in peers]))
        for label, key, fmt in (("success", "success", "{:.0%}"), ("tilt err (deg)", "tilt_deg", "{:.2f}"),
                                (f"leaning tilt (n={s['ICP'].knocked})", "knocked_tilt_deg", _degrees),
                                ("fails t/f/y/s", "modes", _modes), ("time (ms)", "time_ms", "{:.1f}"),
                                ("covariance: in 95 % (n)", "calibration", None),
                                ("well-constrained", "well_constrained", _share)):
            if fmt is None:
                rows.append((result.name, label, _calibration(s["ICP"]), _calibration(s["SG-ICP"]), "",
                             *[_calibration(s[p]) for p in peers]))
                continue
            fmt = fmt.format if isinstance(fmt, str) else fmt
            rows.append((result.name, label, fmt(getattr(s["ICP"], key)), fmt(getattr(s["SG-ICP"], key)), "",
                         *[fmt(getattr(s[p], key)) for p in peers]))
    print_table(f"Registration: Hausdorff means over {run.trials} trials x objects per scenario "
                "(improvement = RMSE/Mean/Max cut by SG-ICP [95 % paired bootstrap interval])",
                ["scenario", "metric", "ICP", "SG-ICP", "improvement", *peers], rows)
    if run.families:
        show_families(run)
    if len(peers) > 1:
        show_speed(run)
    if targets:
        print_table("Targets", ["target", "result", "detail"],
                    [(t.name, "PASS" if t.passed else "FAIL", t.detail) for t in run.targets])


def show_families(run) -> None:
    """One row per scene family: mean surface error (mm) of ICP and SG-ICP with the cut and its paired
    interval, the peers (Open3D, small_gicp's better method), success, failure modes, alias agreement (F10-F11);
    then the worst family again."""
    from bim2rdt.evaluation.stats import best_peer, cut_interval, improvement, worst_family

    peer = "Open3D pt-plane" if "Open3D pt-plane" in run.families[0].stats else None
    small = any(best_peer(r, "mean") for r in run.families)

    def row(result, label):
        s = result.stats
        low, high = cut_interval(result, "mean")
        best = best_peer(result, "mean")
        agreement = result.alias_agreement
        return (label, result.description, f"{1000 * s['ICP'].mean:.1f}", f"{1000 * s['SG-ICP'].mean:.1f}",
                f"{improvement(s['ICP'].mean, s['SG-ICP'].mean):+.1f} % [{low:+.0f}, {high:+.0f}]",
                *([f"{1000 * s[peer].mean:.1f}"] if peer else []),
                *([f"{1000 * s[best].mean:.1f} ({best.split()[1]})" if best else "-"] if small else []),
                f"{s['ICP'].success:.0%} / {s['SG-ICP'].success:.0%}",
                f"{_modes(s['ICP'].modes)} -> {_modes(s['SG-ICP'].modes)}",
                f"{agreement[0]:.1%} ({agreement[1]})" if agreement else "-",
                f"{_calibration(s['ICP'])} / {_calibration(s['SG-ICP'])}")

    rows = [row(r, r.name) for r in run.families]
    worst = worst_family(run.families)
    rows.append(row(worst, f"worst family ({worst.name})"))
    print_table(f"Scene families: mean surface error (mm) over {run.trials} trials x 3 objects "
                "(cut by SG-ICP [95 % paired bootstrap interval])",
                ["family", "scene", "ICP", "SG-ICP", "cut", *([peer] if peer else []),
                 *(["small_gicp best 1T"] if small else []), "success ICP / SG", "fails t/f/y/s ICP -> SG",
                 "alias agreement (n)", "cov. in 95 % (n) ICP / SG"], rows)


def show_speed(run) -> None:
    """Median time per object over S1-S4 of every method, and SG-ICP's ratio to it."""
    from bim2rdt.evaluation.runs import speed_record

    speed = speed_record(run.results)
    print_table("Speed over S1-S4: median time per object (same starts, same restarts, same run)",
                ["method", "median ms", "SG-ICP / method"],
                [(m, f"{ms:.1f}", f"{speed['sg_icp_ratio'][m]:.2f}x" if m in speed["sg_icp_ratio"] else "")
                 for m, ms in speed["median_ms"].items()])


def _calibration(stats) -> str:
    """Share of judged estimates inside their 95 % covariance ellipsoid and how many were judged; '-' for a
    method that reports no covariance (a peer)."""
    return "-" if stats.calibrated == 0 else f"{stats.calibration:.2f} ({stats.calibrated})"


def _share(value: float) -> str:
    return "-" if value != value else f"{value:.0%}"


def _degrees(value: float) -> str:
    """A median in degrees, or '-' when there was nothing to take it over (no leaning object in the run)."""
    return "-" if value != value else f"{value:.2f}"


def _modes(counts: dict[str, int]) -> str:
    """Failure counts as 'tilt/flip/yaw/slide' (see bim2rdt.sim.truth.FAILURE_MODES)."""
    return "/".join(str(counts.get(mode, 0)) for mode in ("tilt", "flip", "yaw", "slide"))


def _open3d_available() -> bool:
    try:
        import open3d  # noqa: F401
    except ImportError:
        return False
    return True


class step_progress:
    """A rich progress bar on stderr whose ``tick()`` advances one step (a trial, a frame, a station); the
    HAV commands' :func:`bim2rdt.cli.hav_output.progress` is told the count done instead."""

    def __init__(self, total: int, label: str) -> None:
        from rich.console import Console
        from rich.progress import Progress

        self._bar = Progress(console=Console(stderr=True), transient=True)  # keeps --json stdout clean
        self._task = self._bar.add_task(label, total=total)

    def __enter__(self):
        self._bar.start()
        return lambda: self._bar.advance(self._task)

    def __exit__(self, *exc) -> None:
        self._bar.stop()
