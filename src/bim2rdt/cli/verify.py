"""`bim2rdt verify MODEL.ifc SOURCE`: a real recording or scan localized on its BIM and checked against it."""

from __future__ import annotations

import json
import math
from pathlib import Path

import typer

from bim2rdt.cli.common import console, out_path, print_json, print_table, writable_folder


def register(app: typer.Typer, bench_app: typer.Typer) -> None:
    app.command("verify")(verify_command)


def verify_command(
    ifc_file: Path = typer.Argument(..., help="The BIM (IFC4 to write the twin back; IFC2X3 still verifies)."),
    source: Path = typer.Argument(..., help="A recording: an organised .pcd frame, a TUM folder, an Azure Kinect "
                                  ".mkv, PCL grabber TIFFs (what bim2rdt.sources reads); or a scan: "
                                  ".ply .las .laz .e57, an unorganised .pcd."),
    prior: str | None = typer.Option(None, "--prior", help="X,Y,Z,YAW_DEG: the sensor's approximate pose in the "
                                     "model's frame (m, deg: the optical axis' heading from +x, counter-clockwise). "
                                     "Without it the sensor is found on the BIM and tracked."),
    prior_file: Path | None = typer.Option(None, "--prior-file", help="JSON 4x4 T_world_sensor (a list of 4 lists); "
                                           "its roll and pitch are kept."),
    up: str | None = typer.Option(None, "--up", help="UX,UY,UZ: gravity up in the sensor frame (an IMU); sets the "
                                  "prior's roll and pitch (default: the sensor is level)."),
    depth_correction: str | None = typer.Option(None, "--depth-correction", help="GX,GY,GZ (1/m): the depth "
                                                "calibration p_true = p / (1 - g.p)."),
    out: Path = typer.Option(Path("out/verify"), "--out", parser=out_path, callback=writable_folder,
                             help="Folder for twin.json, twin.ifc, issues.bcf, report.html, localization.json."),
    detector: str = typer.Option("cluster", "--detector", help="New objects: 'cluster' (what neither the building "
                                 "nor a planned object explains) or 'none'."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document instead of the summary."),
    topics: str | None = typer.Option(None, "--topics", help="A bag's topics by role, ROLE=/topic,... (roles: colour, "
                                      "depth, camera_info, imu, odometry); the others are found by message type."),
    every: int | None = typer.Option(None, "--every", min=1, help="Keep every N-th frame of the recording."),
    max_frames: int | None = typer.Option(None, "--max-frames", min=1, help="Stop after this many frames."),
    storey: str | None = typer.Option(None, "--storey", help="Without a prior, search only this storey (name or "
                                      "GlobalId) for the sensor; default: every storey."),
    publish: Path | None = typer.Option(None, "--publish", help="Also write the results as a ROS 2 bag (NAME.mcap: "
                                        "the rosbag2 folder NAME/): /tf map->odom from the fixes, /bim2rdt/pose, "
                                        "/bim2rdt/objects, /map, /keepout_filter_mask."),
) -> None:
    """Localize each frame on the BIM's walls and slabs, check every planned object in view and find new ones,
    record them in a twin and export it."""
    from bim2rdt.bim import load_ifc
    from bim2rdt.config import get_settings, ifc_cache_dir
    from bim2rdt.verify import VerifyConfig, levelled, prior_pose, record_twin, verify_frames, write_outputs
    from bim2rdt.verify.outputs import verdict_counts

    if detector not in ("cluster", "none"):
        raise _bad(f"--detector must be 'cluster' or 'none', not {detector!r}")
    if prior is not None and prior_file is not None:
        raise _bad("give --prior or --prior-file, not both")
    up_sensor = _numbers(up, 3, "--up") if up else None
    settings = get_settings()
    model = load_ifc(ifc_file, cache_dir=ifc_cache_dir(settings))
    T_prior = None
    if prior is not None:
        x, y, z, yaw = _numbers(prior, 4, "--prior")
        T_prior = prior_pose((x, y, z), yaw, up_sensor)
    elif prior_file is not None:
        T_prior = _prior_file(prior_file)
        if up_sensor is not None:
            T_prior = levelled(T_prior, up_sensor)
    if T_prior is not None:
        _inside(model, T_prior[:3, 3])
    if storey is not None and not any(storey in (s.name, s.global_id) for s in model.storeys):
        raise _bad(f"{ifc_file.name} has no storey {storey!r} (its storeys: "
                   f"{', '.join(str(s.name) for s in model.storeys) or 'none'})")
    correction = _numbers(depth_correction, 3, "--depth-correction") if depth_correction else None
    if topics is not None and not _is_bag(source):
        raise _bad("--topics is for ROS bags (.mcap, .db3, .bag, a rosbag2 folder)")
    options = {"topics": topics, "every": every, "max_frames": max_frames,
               "sync_tolerance": settings.ros.sync_tolerance} if _is_bag(source) else {}
    frames = _frames(source, correction, {k: v for k, v in options.items() if v is not None})
    if not _is_bag(source) and (every or max_frames):
        frames = _Subsampled(frames, every or 1, max_frames)
    config = VerifyConfig(find_new=detector != "none", min_fitness=settings.twin.min_fitness)
    with _progress(frames, as_json, every, max_frames) as tick:
        result = verify_frames(frames, model, T_prior, config, progress=lambda frame: tick("frame"), storey=storey)
        with record_twin(result, model, out, settings.twin) as twin:
            files = write_outputs(result, twin, out)
            counts = verdict_counts(twin.state())
            if publish is not None:
                published = _publish(publish, result, twin.state(), model, out)
            tick("twin")
    summary = {"frames": len(result.frames), "localized": sum(f.accepted for f in result.frames),
               "verdicts": {k: v for k, v in counts.items() if k != "not observed"},
               "miscalibrated": result.miscalibrated, "warnings": result.warnings,
               "seconds_per_frame": round(sum(f.seconds for f in result.frames) / len(result.frames), 2),
               "dropped": result.drop_counts, "source_warnings": result.source_warnings,
               "out": str(out), "ifc_note": files.ifc_note}
    if publish is not None:
        summary["published"] = str(published)
    if as_json:
        print_json(summary)
        return
    print_table(f"verify {ifc_file.name} with {source.name}", ("frame", "source", "localized", "residual cm",
                                                              "inliers", "s", "note"),
                [(f.index, f.source, "yes" if f.accepted else "no",
                  "-" if f.residual is None else f"{100 * f.residual:.1f}", f.inliers, f"{f.seconds:.1f}",
                  f.reason or (f.depth.reason if f.depth else "")) for f in result.frames[:20]])
    console.print("verdicts: " + (", ".join(f"{v} {k}" for k, v in summary["verdicts"].items() if v)
                                  or "none (no frame localized, or nothing in view)"))
    for warning in result.warnings[:5]:
        console.print(f"[bold red]warning:[/] {warning}; its verdicts are unverified")
    for warning in result.source_warnings:
        console.print(f"[bold red]warning:[/] {warning}")
    if result.dropped:
        console.print(f"dropped {len(result.dropped)} frames: "
                      + ", ".join(f"{n} {k}" for k, n in result.drop_counts.items()) + " (localization.json)")
    console.print(f"wrote {out}/: twin.json, issues.bcf, localization.json, report.html"
                  + (", twin.ifc" if files.ifc else f" (no twin.ifc: {files.ifc_note})"))


def _publish(path: Path, result, states, model, out: Path) -> Path:
    """The results bag (:mod:`bim2rdt.verify.publish`) and the Nav2 maps its grids equal (``out/maps``)."""
    from bim2rdt.planning import OccupancyGrid
    from bim2rdt.verify.publish import publish_results

    grid = OccupancyGrid.from_bim(model).with_zones(model.zones)
    grid.save_nav2(out / "maps", "site")
    return publish_results(path, result.frames, states, model, grid)


def _bad(message: str) -> Exception:
    """A one-line input error: exit 1, as every bad input of verify (typer's usage errors exit 2)."""
    from bim2rdt.verify.errors import VerifyError

    return VerifyError(message)


SCAN_SUFFIXES = (".ply", ".las", ".laz", ".e57")


BAG_SUFFIXES = (".mcap", ".db3", ".bag")


class _Subsampled:
    """Every N-th frame of a source, at most ``limit``."""

    def __init__(self, frames, every: int, limit: int | None) -> None:
        self.frames, self.every, self.limit = frames, every, limit

    def __iter__(self):
        import itertools

        return itertools.islice(iter(self.frames), 0, None if self.limit is None else self.limit * self.every,
                                self.every)


def _is_bag(source: Path) -> bool:
    return source.suffix.lower() in BAG_SUFFIXES or (source.is_dir() and (source / "metadata.yaml").is_file())


FRAME_STAGES = {"frame": "frames verified", "twin": "twin recorded and exported"}


def _progress(frames, quiet: bool, every: int | None, max_frames: int | None):
    """``tick(stage)`` (:class:`~bim2rdt.cli.progress.StageProgress`): on a terminal a bar with the frames done
    (of the source's length when it knows it: a bag), the time spent and left; piped, one plain line per stage
    (its count and time) and one every half minute in a long one. ``quiet`` (--json): nothing."""
    from contextlib import nullcontext

    from bim2rdt.cli.progress import StageProgress

    if quiet:
        return nullcontext(lambda stage: None)
    expected = getattr(frames, "expected_frames", None)
    totals = {"twin": 1}
    if expected:
        total = -(-expected // (every or 1))
        totals["frame"] = min(total, max_frames) if max_frames else total
    return StageProgress(console, FRAME_STAGES, totals)


def _frames(source: Path, correction, extra: dict | None = None):
    """The source's frames (``open_source``), or a scan as one cloud (``read_cloud``: .ply .las .laz .e57, and
    a .pcd that is not organised), with the depth correction applied."""
    from bim2rdt.sources import SourceError, correct_points, open_source, read_cloud

    options = {"depth_correction": correction} if correction is not None else {}
    options.update(extra or {})
    if source.suffix.lower() not in SCAN_SUFFIXES:
        try:
            return open_source(source, **options)
        except SourceError as error:
            if "not organised" not in str(error):
                raise
    cloud = read_cloud(source)
    if correction is not None:
        from dataclasses import replace

        cloud = replace(cloud, points=correct_points(cloud.points, correction))
    return [cloud]


def _numbers(text: str, count: int, option: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != count or not all(math.isfinite(v) for v in values):
        raise _bad(f"{option} needs {count} comma-separated numbers, got {text!r}")
    return values


def _prior_file(path: Path):
    import numpy as np

    try:
        T = np.asarray(json.loads(path.read_text()), dtype=float)
    except (OSError, ValueError, TypeError) as error:
        raise _bad(f"--prior-file {path}: {str(error).splitlines()[0]}") from None
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise _bad(f"--prior-file {path}: expected a 4x4 matrix (a list of 4 lists), got shape {T.shape}")
    R = T[:3, :3]
    if np.abs(R @ R.T - np.eye(3)).max() > 1e-3 or np.linalg.det(R) < 0:
        raise _bad(f"--prior-file {path}: not a rigid transform")
    return T


def _inside(model, position) -> None:
    """A prior farther than 2 m outside the model's permanent elements is refused."""
    import numpy as np

    from bim2rdt.localization.cloud import OccludedMap
    from bim2rdt.localization.errors import LocalizationError

    try:
        low, high = OccludedMap.of(model).permanent.mesh.bounds
    except LocalizationError as error:
        raise _bad(f"{model.path.name}: {error}") from None
    if np.any(position < low - 2.0) or np.any(position > high + 2.0):
        raise _bad(f"the prior {np.round(position, 2).tolist()} lies outside the model (its walls and "
                                 f"slabs span {np.round(low, 1).tolist()} to {np.round(high, 1).tolist()})")
