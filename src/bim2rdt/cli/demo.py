"""`bim2rdt demo`: the main job on the embedded default site."""

from __future__ import annotations

from pathlib import Path

import typer

from bim2rdt.cli.common import console, out_path, print_table, run_folder


def register(app: typer.Typer, bench_app: typer.Typer) -> None:
    app.command("demo")(demo_command)


def demo_command(
    out: Path = typer.Option(Path("out/demo"), "--out", parser=out_path, callback=run_folder,
                              help="Output folder (twin IFC, report, plots, JSON)."),
    trials: int = typer.Option(6, "--trials", min=1, help="Seeded trials per registration scenario."),
    workers: int = typer.Option(2, "--workers", min=1, help="Workers with vibration wearables."),
    minutes: float = typer.Option(60.0, "--minutes", min=1.0, help="Minutes of tool work per worker."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the simulated site changes, sensor noise and trials."),
    detector: str | None = typer.Option(None, "--detector",
                                        help="What reads the robot's frames on the embedded site: geometric (the "
                                             "default: scan-vs-BIM, no weights), yoloe (local weights) or ideal (the "
                                             "renderer's masks: an upper bound)."),
    yoloe_weights: Path | None = typer.Option(None, "--yoloe-weights", help="Local YOLOE .pt, for --detector yoloe."),
    yoloe_embeddings: Path | None = typer.Option(None, "--yoloe-embeddings",
                                                 help="Local .npz prompt embeddings, for --detector yoloe."),
    ifc: Path | None = typer.Option(None, "--ifc", exists=True, dir_okay=False,
                                    help="Run the loop on this building instead (IFC4; IFC2X3 runs without IFC "
                                         "write-back): site objects are placed on its ground floor."),
    objects: int = typer.Option(7, "--objects", min=1, max=7,
                                help="With --ifc: site objects placed, one per room (fewer: fewer stations, a "
                                     "quicker look at the same loop)."),
    record: Path | None = typer.Option(None, "--record", help="Also write the robot's run as a ROS 2 bag (NAME.mcap: "
                                       "the rosbag2 folder NAME/ with NAME.mcap and metadata.yaml): RealSense "
                                       "colour + depth + CameraInfo + IMU, /tf with the drifting odometry."),
    publish: Path | None = typer.Option(None, "--publish", help="Also write the results as a ROS 2 bag (NAME.mcap: "
                                        "the rosbag2 folder NAME/), as verify --publish: /tf map->odom from the "
                                        "robot's BIM fixes, /bim2rdt/pose, /bim2rdt/objects, /map, "
                                        "/keepout_filter_mask."),
    targets: int | None = typer.Option(None, "--targets", min=1, help="Stations for the first N site objects only "
                                       "(a short day; what they see of the others is judged too)."),
) -> None:
    """Run a simulated day on the embedded site: the robot verifies the BIM's site objects with SG-ICP, the twin
    is updated and hand-arm vibration exposure becomes IfcEvent/IfcTask records; then the paper's registration
    scenarios. Writes site.ifc, site_twin.ifc, report.md, plots and JSON into --out."""
    from bim2rdt.cli.progress import StageProgress
    from bim2rdt.cli.registration import show_run
    from bim2rdt.cli.twin import follow_up_command
    from bim2rdt.demo.run import run_demo
    from bim2rdt.perception.detectors import DEFAULT_DETECTOR, check_detector
    from bim2rdt.perception.errors import PerceptionError
    from bim2rdt.sim.scenarios import SCENARIOS

    detector = detector or DEFAULT_DETECTOR
    yoloe = (yoloe_weights, yoloe_embeddings) if detector == "yoloe" else None
    try:
        check_detector(detector, yoloe)
    except PerceptionError as error:
        raise typer.BadParameter(str(error)) from None
    if ifc is not None and (record is not None or targets is not None or publish is not None):
        raise typer.BadParameter("--record, --publish and --targets run on the embedded site, not with --ifc")

    stages = {"bim": "site model read", "site": "site objects placed", "station": "robot station",
              "twin": "objects registered, twin updated", "hav": "vibration day monitored",
              "trial": "registration trial"}
    totals = {"bim": 1, "site": 1, "hav": 1, "twin": 1} | ({"trial": len(SCENARIOS) * trials} if ifc is None else {})
    with StageProgress(console, stages, totals) as tick:
        if ifc is not None:
            from bim2rdt.demo.ifc_day import run_ifc_demo

            result = run_ifc_demo(ifc, out, seed=seed, workers=workers, minutes=minutes, tick=tick, detector=detector,
                                  yoloe=yoloe, objects=objects)
        else:
            result = run_demo(out, trials=trials, seed=seed, workers=workers, minutes=minutes, tick=tick,
                              detector=detector, yoloe=yoloe, record=record, max_targets=targets,
                              publish=publish)
    _show_site_day(result)
    if result.registration is not None:
        show_run(result.registration, targets=False)
        console.print(f"(registration: {trials} trials per scenario, a quick look; the paper's targets are judged "
                      "on 50 trials by `bim2rdt bench registration`)")
    _fail_without_a_station(result.site_day, out)
    twin = result.site_day.twin_path or f"not written back ({result.site_day.model.schema}: IFC write-back needs IFC4)"
    if record is not None:
        from bim2rdt.sources.bag_writer import bag_folder, storage_file

        console.print(f"recorded the robot's run: {bag_folder(record)}/ ({storage_file(record).name} + metadata.yaml)")
    if getattr(result, "published", None) is not None:
        console.print(f"published the results: {result.published}/ (/tf map->odom, /bim2rdt/pose, /bim2rdt/objects, "
                      "/map, /keepout_filter_mask)")
    console.print(f"twin: {twin} (history {out / 'twin.db'}, issues {out / 'site_issues.bcf'}); report: "
                  f"{result.report['html']} and {result.report['report']}; plots and JSON in {out}")
    console.print(f"see the twin: {follow_up_command(result.site_day.model.path, out / 'twin.db')}", markup=False,
                  highlight=False, soft_wrap=True)


def _fail_without_a_station(day, out: Path) -> None:
    """A day on which the robot visited no station verified nothing: an error (exit 1) that says why, not an
    empty table and exit 0."""
    from bim2rdt.demo.routes import why_no_station
    from bim2rdt.planning import PlanningError

    why = why_no_station(day.route) if day.route is not None else None
    if why is not None:
        raise PlanningError(f"the robot visited no station, so nothing was verified: {why} (report: "
                            f"{out / 'report.md'})")


def _show_site_day(result) -> None:
    from bim2rdt.demo.site_report import OBSERVATION_COLUMNS, observation_cells, observation_rows, set_aside_line

    print_table("Robot mission: BIM objects verified with SG-ICP", OBSERVATION_COLUMNS,
                [observation_cells(r) for r in observation_rows(result.site_day)])
    if result.site_day.mission.set_aside:
        console.print(set_aside_line(result.site_day))
    if result.site_day.route is not None:
        from bim2rdt.demo.routes import route_rows

        summary = result.site_day.route.summary()
        print_table(f"Robot route: {summary['stations']} stations, {summary['walked_m']} m walked on planned paths; "
                    "replans", ("time (UTC)", "at (x, y) m", "why"), route_rows(result.site_day.route))
    _show_localization(result.site_day)
    events = [e for e in result.site_day.hav_events if not e.kind.endswith("predicted")]
    print_table("Hand-arm vibration events (written to the twin as IfcEvent/IfcTask)",
                ("event", "worker", "A(8) m/s²"),
                [(e.kind, e.subject[:8], f"{e.data.get('day_a8', float('nan')):.2f}") for e in events])


def _show_localization(day) -> None:
    from bim2rdt.demo.localization_report import localization_record, localization_tables

    if day.localization is not None:
        for title, columns, rows in localization_tables(localization_record(day.localization, day.mission,
                                                                            day.reality.truth)):
            print_table(title, columns, rows)
