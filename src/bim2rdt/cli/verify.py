"""`bim2rdt verify MODEL.ifc SOURCE`: a real recording or scan localized on its BIM and checked against it."""

from __future__ import annotations

import json
import math
from pathlib import Path

import typer

from bim2rdt.cli.common import console, out_path, print_json, print_table, set_folder


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
    depth_scale: float | None = typer.Option(None, "--depth-scale", help="Raw depth units per metre, overriding "
                                            "the recording's own (1000: millimetres, 5000: TUM PNGs); for a scan, "
                                            "its coordinate units per metre (1000: a scan in millimetres)."),
    intrinsics: Path | None = typer.Option(None, "--intrinsics", help="JSON file of the depth camera's pinhole "
                                           "{\"fx\", \"fy\", \"cx\", \"cy\"} (pixels; optionally \"width\", "
                                           "\"height\"), overriding the recording's (a PNG pair without "
                                           "intrinsics.json)."),
    out: Path = typer.Option(Path("out/verify"), "--out", parser=out_path, callback=set_folder,
                             help="Folder for twin.json, twin.ifc, issues.bcf, report.html, localization.json, "
                             "config.json (the settings that ran), twin.db, structure.json, deviation.ply and deviation/ (a PNG per "
                             "frame): written as one set when the run ends "
                             "(an interrupted run leaves the earlier set as it was)."),
    detector: str = typer.Option("cluster", "--detector", help="New objects: 'cluster' (what neither the building "
                                 "nor a planned object explains) or 'none'."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document instead of the summary."),
    topics: str | None = typer.Option(None, "--topics", help="A bag's topics by role, ROLE=/topic,... (roles: colour, "
                                      "depth, camera_info, imu, odometry); the others are found by message type."),
    every: int | None = typer.Option(None, "--every", min=1, help="Keep every N-th frame of the recording."),
    max_frames: int | None = typer.Option(None, "--max-frames", min=1, help="Stop after this many frames."),
    storey: str | None = typer.Option(None, "--storey", help="Without a prior, search only this storey (name or "
                                      "GlobalId) for the sensor; default: every storey."),
    own_poses: str = typer.Option("world", "--own-poses", help="How a recording's own poses (a bag's TF, TUM "
                                  "ground truth) are read without --prior: 'world' (in the model's frame until a "
                                  "fix is accepted) or 'odometry' (a robot's map/odom frame never aligned to the "
                                  "BIM: the first frame is found on the BIM and its places carried through the "
                                  "sweep by the poses' steps until one is left)."),
    publish: Path | None = typer.Option(None, "--publish", help="Also write the results as a ROS 2 bag (NAME.mcap: "
                                        "the rosbag2 folder NAME/): /tf map->odom from the fixes, /bim2rdt/pose, "
                                        "/bim2rdt/objects, /map, /keepout_filter_mask."),
) -> None:
    """Localize each frame on the BIM's walls and slabs, check every planned object in view and find new ones,
    record them in a twin and export it.

    Exit status: 0 when at least one frame was localized (a partial fix, with a direction the view leaves free,
    counts); 1 for bad input (one line); 3 when no frame was localized: the outputs are written and the summary
    says why (no prior, a prior off or at the wrong height, the wrong model)."""
    from bim2rdt.bim import load_ifc
    from bim2rdt.config import get_settings, ifc_cache_dir
    from bim2rdt.sources import limit_memory, open_recording
    from bim2rdt.verify import (levelled, prior_pose, read_prior_file, record_twin, verify_frames,
                                 write_outputs)
    from bim2rdt.verify.output_set import OutputSet
    from bim2rdt.verify.outputs import verdict_counts
    from bim2rdt.verify.report import FrameCapture
    from bim2rdt.verify.report.rows import element_rows
    from bim2rdt.structure import STRUCTURE_STATUSES
    from bim2rdt.verify.structure_run import StructureRun

    if detector not in ("cluster", "none"):
        raise _bad(f"--detector must be 'cluster' or 'none', not {detector!r}")
    if prior is not None and prior_file is not None:
        raise _bad("give --prior or --prior-file, not both")
    if own_poses not in ("world", "odometry"):
        raise _bad(f"--own-poses must be 'world' or 'odometry', not {own_poses!r}")
    up_sensor = _numbers(up, 3, "--up") if up else None
    T_prior = None  # read before the model: a bad prior is refused in a second, not after a long load
    if prior is not None:
        x, y, z, yaw = _numbers(prior, 4, "--prior")
        T_prior = prior_pose((x, y, z), yaw, up_sensor)
    elif prior_file is not None:
        T_prior = read_prior_file(prior_file)
        if up_sensor is not None:
            T_prior = levelled(T_prior, up_sensor)
    settings = get_settings()
    limit_memory(settings.sources.memory_cap_bytes())  # every reader refuses a recording over the cap
    model = load_ifc(ifc_file, cache_dir=ifc_cache_dir(settings))
    if T_prior is not None:
        _inside(model, T_prior[:3, 3])
    if storey is not None and not any(storey in (s.name, s.global_id) for s in model.storeys):
        raise _bad(f"{ifc_file.name} has no storey {storey!r} (its storeys: "
                   f"{', '.join(str(s.name) for s in model.storeys) or 'none'})")
    correction = _numbers(depth_correction, 3, "--depth-correction") if depth_correction else None
    if depth_scale is not None and not (math.isfinite(depth_scale) and depth_scale > 0):
        raise _bad(f"--depth-scale must be a positive number of raw units per metre (1000: millimetres), got "
                   f"{depth_scale!r}")
    recording = open_recording(source, depth_correction=correction, topics=topics, every=every,
                               max_frames=max_frames, sync_tolerance=settings.ros.sync_tolerance,
                               depth_scale=depth_scale,
                               intrinsics=_intrinsics(intrinsics) if intrinsics is not None else None)
    config = settings.verify.model_copy(update={"find_new": detector != "none"})
    frames, output = FrameCapture(recording), OutputSet(out)
    try:
        with output, _progress(recording.expected_frames, as_json) as tick:
            structure = StructureRun(model, output.folder, settings.structure)
            result = verify_frames(frames, model, T_prior, config, progress=lambda frame: tick("frame"),
                                   look=structure.look, storey=storey, own_poses=own_poses)
            judged = structure.finish()
            with record_twin(result, model, output.folder, settings.twin) as twin:
                counts = verdict_counts(twin.state())  # the objects' verdicts; the structure's are counted apart
                structure.record(twin, judged)
                files = write_outputs(result, twin, output.folder, frames.views,
                                      f"verify {ifc_file.name} with {source.name}", settings.progress)
                _record_run(output.folder, settings, {
                    "ifc": str(ifc_file.resolve()), "source": str(source.resolve()),
                    "prior": None if T_prior is None else T_prior.tolist(), "detector": detector, "every": every,
                    "max_frames": max_frames, "depth_scale": depth_scale, "depth_correction": correction,
                    "own_poses": own_poses})
                states = twin.state()
                if publish is not None:
                    published = _publish(publish, result, states, model, output.folder)
                tick("twin")
            output.commit()
    except BaseException:
        _say_kept(output)
        raise
    summary = {"frames": len(result.frames), "localized": result.localized,
               "partial": sum(f.fix == "partial" for f in result.frames),
               "verdicts": {k: v for k, v in counts.items() if k != "not observed"},
               "structure": {s: sum(j.status == s for j in judged) for s in STRUCTURE_STATUSES},
               "miscalibrated": result.miscalibrated, "warnings": result.warnings,
               "seconds_per_frame": round(sum(f.seconds for f in result.frames) / len(result.frames), 2),
               "dropped": result.drop_counts, "source_warnings": result.source_warnings,
               "out": str(out), "files": output.committed, "ifc_note": files.ifc_note}
    if publish is not None:
        summary["published"] = str(published)
    if not result.localized:
        summary["why"] = result.why_none_localized
    if as_json:
        print_json(summary)
        _exit_status(result)
        return
    print_table(f"verify {ifc_file.name} with {source.name}", ("frame", "source", "localized", "fixed at x, y, z m",
                                                              "heading °", "free directions", "residual cm",
                                                              "inliers", "s", "note"),
                [(f.index, f.source, _fix_label(f), *_fix(f),
                  "-" if f.residual is None else f"{100 * f.residual:.1f}", f.inliers, f"{f.seconds:.1f}",
                  f.reason or (f.depth.reason if f.depth else "")) for f in result.frames[:20]])
    console.print("verdicts: " + (", ".join(f"{v} {k}" for k, v in summary["verdicts"].items() if v)
                                  or "none (no frame localized, or nothing in view)"))
    for row in element_rows(states, result.frames, model):
        if row.state.status.value in ("deviating", "missing", "new"):
            console.print(f"  {row.state.status.value}: {row.name or row.state.family or '-'} "
                          f"({row.state.family or row.state.ifc_class or 'object'}) {row.state.global_id}: "
                          f"{row.reason}; frames {', '.join(map(str, row.frames)) or '-'}", highlight=False)
    for warning in result.warnings[:5]:
        console.print(f"[bold red]warning:[/] {warning}; its verdicts are unverified")
    for warning in result.source_warnings:
        console.print(f"[bold red]warning:[/] {warning}")
    if result.dropped:
        console.print(f"dropped {len(result.dropped)} frames: "
                      + ", ".join(f"{n} {k}" for k, n in result.drop_counts.items()) + " (localization.json)")
    console.print("structure: " + (", ".join(f"{v} {k}" for k, v in summary["structure"].items() if v)
                                   or "none judged"))
    console.print(f"wrote {out}/: {', '.join(output.committed)}"
                  + ("" if files.ifc else f" (no twin.ifc: {files.ifc_note})"), highlight=False)
    if publish is not None:
        console.print(f"published the results bag: {published}/ (and its Nav2 maps: {out}/maps/)", highlight=False)

    if summary["partial"]:
        console.print(f"{summary['partial']} partial fixes: the view leaves a direction free (a wall seen alone "
                      "pins only the distance to it); their objects are judged only along what the view fixes")
    if not result.localized:
        console.print(f"[bold red]{summary['why']}[/]")
    _exit_status(result)


def _fix(frame) -> tuple[str, str, str]:
    """A frame's fixed position, heading and the directions its view left free."""
    from bim2rdt.verify import heading_deg

    if not frame.accepted or frame.pose is None:
        return "-", "-", "-"
    free = ", ".join(frame.free) or "none"  # in words: "x free", "free along 35 deg", "yaw free"
    return ", ".join(f"{v:.2f}" for v in frame.pose[:3, 3]), f"{heading_deg(frame.pose):.1f}", free


def _say_kept(output) -> None:
    """After a failed or interrupted run: what ``--out`` holds (its outputs were not moved in, or were)."""
    if output.committed:
        kept = f"this run's outputs are complete in {output.out_dir}: {', '.join(output.committed)}"
    elif output.previous():
        kept = (f"kept {output.out_dir} as the earlier run left it ({', '.join(output.previous())}); nothing of "
                "this run was kept")
    else:  # nothing to say beside the error itself (one line)
        return
    typer.secho(f"verify stopped: {kept}", err=True, fg=typer.colors.YELLOW)


NO_FIX_EXIT = 3
"""verify's exit status when no frame was localized (its outputs are written; the summary says why)."""


def _exit_status(result) -> None:
    """Exit with :data:`NO_FIX_EXIT` when no frame was localized."""
    if not result.localized:
        raise typer.Exit(NO_FIX_EXIT)


def _fix_label(frame) -> str:
    """"yes", "partial (x free)" or "no" for the frames table."""
    if frame.fix == "partial":
        return f"partial ({', '.join(frame.free)})"
    return "yes" if frame.accepted else "no"


def _record_run(out: Path, settings, arguments: dict) -> None:
    """``out/config.json``: the settings that ran (every section, ``verify`` and ``localization`` resolved,
    secrets masked), the command's arguments and the versions, as every run records them."""
    from bim2rdt.atomic import write_bytes_atomic
    from bim2rdt.config import settings_record
    from bim2rdt.evaluation.runs import versions

    record = {"settings": settings_record(settings), **arguments, "versions": versions()}
    write_bytes_atomic(out / "config.json", json.dumps(record, indent=2, default=str).encode("utf-8"))


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


FRAME_STAGES = {"frame": "frames verified", "twin": "twin recorded and exported"}


def _progress(expected_frames: int | None, quiet: bool):
    """``tick(stage)`` (:class:`~bim2rdt.cli.progress.StageProgress`): on a terminal a bar with the frames done
    (of the recording's length when it knows it: a bag, a scan), the time spent and left; piped, one plain line
    per stage (its count and time) and one every half minute in a long one. ``quiet`` (--json): nothing."""
    from contextlib import nullcontext

    from bim2rdt.cli.progress import StageProgress

    if quiet:
        return nullcontext(lambda stage: None)
    totals = {"twin": 1} | ({"frame": expected_frames} if expected_frames else {})
    return StageProgress(console, FRAME_STAGES, totals)


def _intrinsics(path: Path) -> dict:
    """``--intrinsics FILE``: a JSON object of fx, fy, cx, cy (and optionally width, height), numbers."""
    try:
        values = json.loads(path.read_text())
    except (OSError, ValueError) as error:
        raise _bad(f"--intrinsics {path}: {str(error).splitlines()[0]}") from None
    needed, allowed = {"fx", "fy", "cx", "cy"}, {"fx", "fy", "cx", "cy", "width", "height"}
    if not isinstance(values, dict) or not needed <= set(values) or set(values) - allowed:
        raise _bad(f"--intrinsics {path}: expected a JSON object with fx, fy, cx, cy (and optionally width, height)")
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0
               for v in values.values()):
        raise _bad(f"--intrinsics {path}: fx, fy, cx, cy, width and height must be positive numbers")
    return values


def _numbers(text: str, count: int, option: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != count or not all(math.isfinite(v) for v in values):
        raise _bad(f"{option} needs {count} comma-separated numbers, got {text!r}")
    return values


def _inside(model, position) -> None:
    """A prior farther than 2 m outside the model's permanent elements is refused."""
    import numpy as np

    from bim2rdt.localization import LocalizationError, OccludedMap

    try:
        low, high = OccludedMap.of(model).permanent.mesh.bounds
    except LocalizationError as error:
        raise _bad(f"{model.path.name}: {error}") from None
    if np.any(position < low - 2.0) or np.any(position > high + 2.0):
        raise _bad(f"the prior {np.round(position, 2).tolist()} lies outside the model (its walls and "
                                 f"slabs span {np.round(low, 1).tolist()} to {np.round(high, 1).tolist()})")
