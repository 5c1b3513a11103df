"""The global section of ``bench localization``: every station of the simulated tour, and the real office frame,
localized with no prior at all (:func:`~bim2rdt.localization.find_pose`), against Open3D's FPFH + RANSAC global
registration (then its point-to-plane ICP, as Open3D's tutorial pipeline does) on points sampled from the BIM's
permanent surfaces, in the same run.

A station is a success when the pose taken is within ``POSITION_M`` and ``YAW_DEG`` of the truth; "wrong and
confident" when a pose is taken outside that; otherwise the view was refused (ambiguous, no place fits, no floor).
The peer takes whatever RANSAC returns, so each of its answers is confident. Truth is read here only to render
frames and score; the search sees the depth frame (its pose stripped) and, on the tour, the IMU's up. Times are
CPU seconds per search (one core when pinned).

The sweep (``sweep`` in the record): the same frames in the tour's order, no prior, given to
:class:`~bim2rdt.localization.hypotheses.Sweep` with the robot's odometry between stations (the simulator's legged
odometry, :class:`~bim2rdt.sim.odometry.SimulatedOdometry`: 2 % of the distance in a seeded direction, 1 degree of
heading per 10 m, noise) integrated in an odometry frame a random 4-DoF offset away from the BIM's (never aligned
to it): the library sees only the steps between consecutive odometry poses and each frame's IMU up. A station is
scored on the pose taken at its frame, or the one back-filled when a later frame resolved the ambiguity (fixed
from the resolved pose carried back through the odometry chain); its time is its step's, plus its back-fill's.
A station whose view leaves a direction free (a bare wall) is taken from the odometry calibrated on the sweep's
own fixes when that is precise enough (``how``: ``calibrated`` at its frame, ``smoothed`` at the sweep's end from
the fixes on both sides: :meth:`~bim2rdt.localization.Sweep.smooth`); the calibration the sweep ended with is
``sweep_calibration`` (decision 0053).
"""

from __future__ import annotations

import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from bim2rdt.bim import BimModel, load_ifc
from bim2rdt.localization import GlobalSearchConfig, LocalizationError, Sweep, choose, find_pose, refix
from bim2rdt.localization.depth import depth_points
from bim2rdt.localization.planar import compose, from_planar, to_planar, wrap
from bim2rdt.localization.surfaces import permanent_map
from bim2rdt.sim.odometry import SimulatedOdometry
from bim2rdt.sim.site import build_site_ifc
from bim2rdt.sim.tour import render_frame, tour_poses, tour_scene

POSITION_M = 0.05
YAW_DEG = 1.0
OFFICE_YAW_DEG = 2.0
PEER_VOXEL = 0.1


def run_global(out_dir: Path, seed: int = 0, distance: float = 100.0, config: GlobalSearchConfig | None = None,
               peer: bool = True, sensors: Path | None = None, tick=lambda: None, tour: bool = True,
               look_around: bool = True, sweep: bool = True, people: bool = True) -> dict:
    """The tour's stations (unless not ``tour``) and office1 (when ``sensors`` holds it) searched without a
    prior, and the peer on the same frames (JSON-able); with ``look_around``, each station also as the robot
    sees it turning 70 degrees either way (three frames as one cloud, placed by its odometry and IMU); with
    ``sweep``, the stations in order as one sweep on the robot's unaligned, drifting odometry (``sweep``); with
    ``people`` (and ``tour``), the frames that look at the site's people, with and without the whole-thing rule
    (``people``: :func:`run_people`)."""
    cfg = config or GlobalSearchConfig()
    stations = _tour_stations(Path(out_dir), seed, distance, cfg, peer, tick, look_around, sweep) if tour else []
    record = {"tolerance": {"position_m": POSITION_M, "yaw_deg": YAW_DEG}, "stations": stations,
              "summary": _summary(stations, peer)}
    if tour and people:
        record["people"] = run_people(Path(out_dir), seed, cfg)
    if stations and "sweep" in stations[-1]:
        record["sweep_calibration"] = stations[-1]["sweep"].pop("sweep_calibration", None)
    if sensors is not None and (sensors / "pcl" / "office1.pcd").is_file():
        record["office"] = _office(sensors, cfg, peer, Path(out_dir) / "cache")
    return record


def _tour_stations(out_dir: Path, seed: int, distance: float, cfg: GlobalSearchConfig, peer: bool, tick,
                   look_around: bool, sweep: bool = False) -> list[dict]:
    """Each station of a ``distance`` m tour of the embedded site (built in ``out_dir``) searched without a prior,
    by ours and (with ``peer``) by FPFH + RANSAC on the same frame; with ``sweep``, then all of them as one
    sweep (each station's ``sweep`` entry)."""
    model = load_ifc(build_site_ifc(out_dir / "site.ifc"), cache_dir=out_dir / "cache")
    scene = tour_scene(model, seed=seed).scene
    rng = np.random.default_rng(seed)
    ransac = _FpfhRansac(model, seed) if peer else None
    stations, frames = [], []
    poses = tour_poses(distance)
    for index, T_true in enumerate(poses):
        frame = replace(render_frame(scene, T_true, rng), T_world_camera=None)
        up = T_true[:3, :3].T @ np.array([0.0, 0.0, 1.0])  # the IMU's up, in the camera frame
        frames.append((frame, up))
        entry = {"index": index, **_ours(frame, model, up, cfg, T_true, YAW_DEG)}
        if look_around:
            entry["look_around"] = _ours(_looked_around(scene, T_true, seed + index), model, up, cfg, T_true,
                                         YAW_DEG)
        if ransac is not None:
            entry["peer"] = ransac.score(frame, T_true, YAW_DEG)
        stations.append(entry)
        tick()
    if sweep:
        for entry, outcome in zip(stations, run_sweep(model, frames, poses, seed, cfg)):
            entry["sweep"] = outcome
    return stations


ODOMETRY_OFFSET_M = 50.0
"""The sweep's odometry frame stands up to this far from the BIM's (x and y each, uniform), at any heading."""


def run_sweep(model: BimModel, frames: list, poses: list[np.ndarray], seed: int,
              cfg: GlobalSearchConfig | None = None) -> list[dict]:
    """The tour's frames in order as one sweep with no prior (see the module's note): each station's outcome.

    Args:
        model: The site's BIM.
        frames: (frame without its pose, the IMU's up in the camera frame) per station, in order.
        poses: The stations' true T_world_camera (to drive the simulated odometry and to score).
        seed: Seeds the odometry's drift and the odometry frame's offset.
        cfg: The search's settings.

    Returns:
        Per station: outcome, errors, how the pose was found, the places left, seconds (the calibration weighed
            at a station whose view leaves a direction free, ``calibration``); the last station's also holds the
            calibration the sweep ended with (``sweep_calibration``).
    """
    cfg = cfg or GlobalSearchConfig()
    rng = np.random.default_rng(seed + 7919)
    odometry = SimulatedOdometry(seed + 1)
    state = np.r_[rng.uniform(-ODOMETRY_OFFSET_M, ODOMETRY_OFFSET_M, 2), rng.uniform(-1, 1), rng.uniform(-np.pi, np.pi)]
    sweep, previous, out = Sweep(model, cfg), None, []
    for index, ((frame, up), T_true) in enumerate(zip(frames, poses)):
        if index:
            reading = odometry.leg(np.stack([to_planar(poses[index - 1])[0], to_planar(T_true)[0]]))
            state = compose(state, reading.increment)
        T_odom = from_planar(state, to_planar(T_true)[1])  # the robot's odometry pose; its tilt the IMU's
        step = sweep.add(frame, None if previous is None else np.linalg.inv(previous) @ T_odom, up)
        previous = T_odom
        carried = step.places[0].pose if step.pose is None and len(step.places) == 1 else None
        out.append(_scored(step.pose, step.reason, T_true, step.seconds, step.how, len(step.places), carried))
        if step.resolved_at is not None:
            out[-1]["resolved_here"] = True
        for held, prior in step.backfill:
            started = time.process_time()
            fixed = refix(frames[held][0], prior, model, frames[held][1], cfg)
            seconds = out[held]["seconds"] + time.process_time() - started
            taken = fixed.refined and not fixed.degenerate
            why = fixed.reason or f"the back-filled fix leaves a direction free ({out[held].get('reason', '')})"
            out[held] = _scored(fixed.pose if taken else None, why, poses[held], seconds, "backfill", 1,
                                None if taken else fixed.pose)
            out[held]["resolved_at"] = index
            if taken:
                sweep.confirm(held, fixed.pose)
        if step.calibration is not None:
            out[-1]["calibration"] = step.calibration
    started = time.process_time()
    smoothed = sweep.smooth()
    seconds = (time.process_time() - started) / max(len(smoothed), 1)
    for held, pose in smoothed:
        out[held] = {**_scored(pose, "", poses[held], out[held]["seconds"] + seconds, "smoothed", 1),
                     "resolved_at": len(frames) - 1}
    out[-1]["sweep_calibration"] = sweep.calibration.to_json()
    return out


def _scored(pose: np.ndarray | None, reason: str, T_true: np.ndarray, seconds: float, how: str, places: int,
            carried: np.ndarray | None = None) -> dict:
    """A sweep station's entry; a refused one with a single place left (its view leaves a direction free: the
    odometry carries it) gives that place's error too (``carried_position_m``, ``carried_yaw_deg``), not scored."""
    if pose is None:
        entry = {"outcome": "refused", "reason": reason, "how": how, "places": places, "seconds": seconds}
        if carried is not None:
            entry["carried_position_m"], entry["carried_yaw_deg"] = _error(carried, T_true)
        return entry
    position, yaw = _error(pose, T_true)
    right = position <= POSITION_M and abs(yaw) <= YAW_DEG
    return {"outcome": "success" if right else "wrong", "position_m": position, "yaw_deg": yaw, "how": how,
            "places": places, "seconds": seconds}


def _ours(frame, model: BimModel, up, cfg: GlobalSearchConfig, T_true: np.ndarray, yaw_tol: float) -> dict:
    started = time.process_time()
    try:
        candidates = find_pose(frame, model, up=up, config=cfg)
        best, reason = choose(candidates, cfg)
    except LocalizationError as error:
        candidates, best, reason = [], None, str(error)
    seconds = time.process_time() - started
    if best is None:
        return {"outcome": "refused", "reason": reason, "candidates": len(candidates), "seconds": seconds}
    position, yaw = _error(best.pose, T_true)
    right = position <= POSITION_M and abs(yaw) <= yaw_tol
    return {"outcome": "success" if right else "wrong", "position_m": position, "yaw_deg": yaw,
            "candidates": len(candidates), "gravity": best.gravity, "seconds": seconds}


def _error(T: np.ndarray, T_true: np.ndarray) -> tuple[float, float]:
    a, _ = to_planar(T)
    b, _ = to_planar(T_true)
    return float(np.linalg.norm(T[:3, 3] - T_true[:3, 3])), float(np.rad2deg(wrap(a[3] - b[3])))


LOOK_AROUND_DEG = 70.0
"""The turns of a look-around, as ``localize_station`` makes them."""


class _Points:
    def __init__(self, points: np.ndarray) -> None:
        self.points = points


def _looked_around(scene, T_true: np.ndarray, seed: int) -> _Points:
    """The station's frame and two more, the robot turned 70 degrees left and right of it in place: their points
    in the first frame's camera axes, placed by the turns' odometry readings and the IMU's tilt (the simulated
    robot's, drift and all)."""
    from bim2rdt.localization.planar import compose, from_planar
    from bim2rdt.sim.robot import SimulatedRobot
    from bim2rdt.localization import depth_points

    robot = SimulatedRobot(scene, T_true, seed)
    state, tilt = np.zeros(4), to_planar(T_true)[1]
    first = from_planar(state, tilt)
    clouds = [depth_points(robot.capture())]
    for angle in (LOOK_AROUND_DEG, -2 * LOOK_AROUND_DEG):
        turned = robot.turn(np.deg2rad(angle))
        state = compose(state, turned.increment)
        T = np.linalg.inv(first) @ from_planar(state, to_planar(robot.T_world_camera)[1])
        clouds.append(depth_points(turned.frame) @ T[:3, :3].T + T[:3, 3])
    return _Points(np.concatenate(clouds)[::4])


def _summary(stations: list[dict], peer: bool) -> dict:
    def rates(entries: list[dict]) -> dict:
        n = max(len(entries), 1)
        seconds = [e["seconds"] for e in entries]
        return {"stations": len(entries), "success_rate": sum(e["outcome"] == "success" for e in entries) / n,
                "wrong_and_confident_rate": sum(e["outcome"] == "wrong" for e in entries) / n,
                "refused_rate": sum(e["outcome"] == "refused" for e in entries) / n,
                "median_seconds": float(np.median(seconds)) if seconds else None,
                "max_seconds": float(np.max(seconds)) if seconds else None}

    summary = {"ours": rates(stations)}
    if stations and "look_around" in stations[0]:
        summary["look_around"] = rates([s["look_around"] for s in stations])
    if stations and "sweep" in stations[0]:
        summary["sweep"] = rates([s["sweep"] for s in stations])
    if peer:
        summary["peer"] = rates([s["peer"] for s in stations])
    return summary


def _office(sensors: Path, cfg: GlobalSearchConfig, peer: bool, cache_dir: Path) -> dict:
    from bim2rdt.sources import open_source
    from bim2rdt.verify.chain import real_sensor_localization

    folder = sensors / "pcl"
    truth = json.loads((folder / "office1_truth.json").read_text())
    T_true = np.array(truth["T_world_camera"])
    model = load_ifc(folder / "office1.ifc", cache_dir=cache_dir)
    [frame] = list(open_source(folder / "office1.pcd", depth_correction=truth["depth_correction"]["g"]))
    real = cfg.model_copy(update={"fix": real_sensor_localization()})
    record = {"ours": _ours(frame, model, None, real, T_true, OFFICE_YAW_DEG),
              "tolerance": {"position_m": POSITION_M, "yaw_deg": OFFICE_YAW_DEG}}
    if peer:
        record["peer"] = _FpfhRansac(model, 0).score(frame, T_true, OFFICE_YAW_DEG)
    return record


class _FpfhRansac:
    """Open3D's global registration pipeline: FPFH features of the frame's points and of points sampled from the
    BIM's permanent surfaces (both faces of every wall, ``PEER_VOXEL`` apart), RANSAC on feature matches, then
    point-to-plane ICP; 6-DoF, no gravity, no free-space knowledge."""

    def __init__(self, model: BimModel, seed: int) -> None:
        from bim2rdt.evaluation.peers import import_open3d

        self.o3d, self.seed = import_open3d(), seed
        self.o3d.utility.set_verbosity_level(self.o3d.utility.VerbosityLevel.Error)  # its warnings go to stdout
        points, normals = permanent_map(model).samples(PEER_VOXEL / 2, seed=seed)
        self.target, self.target_features = self._features(points, normals)

    def _features(self, points: np.ndarray, normals: np.ndarray | None = None):
        o3d = self.o3d
        cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
        if normals is not None:
            cloud.normals = o3d.utility.Vector3dVector(normals)
        cloud = cloud.voxel_down_sample(PEER_VOXEL)
        if normals is None:
            cloud.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2 * PEER_VOXEL, max_nn=30))
        features = o3d.pipelines.registration.compute_fpfh_feature(
            cloud, o3d.geometry.KDTreeSearchParamHybrid(radius=5 * PEER_VOXEL, max_nn=100))
        return cloud, features

    def pose(self, frame) -> np.ndarray:
        """T_world_camera by FPFH + RANSAC, refined by point-to-plane ICP."""
        o3d = self.o3d
        reg = o3d.pipelines.registration
        o3d.utility.random.seed(self.seed)
        source, features = self._features(depth_points(frame, 2, 0.3, 8.0))
        distance = 1.5 * PEER_VOXEL
        coarse = reg.registration_ransac_based_on_feature_matching(
            source, self.target, features, self.target_features, True, distance,
            reg.TransformationEstimationPointToPoint(False), 3,
            [reg.CorrespondenceCheckerBasedOnEdgeLength(0.9), reg.CorrespondenceCheckerBasedOnDistance(distance)],
            reg.RANSACConvergenceCriteria(100000, 0.999))
        fine = reg.registration_icp(source, self.target, PEER_VOXEL, coarse.transformation,
                                    reg.TransformationEstimationPointToPlane())
        return np.asarray(fine.transformation)

    def score(self, frame, T_true: np.ndarray, yaw_tol: float) -> dict:
        started = time.process_time()
        pose = self.pose(frame)
        seconds = time.process_time() - started
        position, yaw = _error(pose, T_true)
        right = position <= POSITION_M and abs(yaw) <= yaw_tol
        return {"outcome": "success" if right else "wrong", "position_m": position, "yaw_deg": yaw,
                "seconds": seconds}


PERSON_SHARE = 0.02
"""A frame has a person in view when at least this share of its returns are a person's."""
PEOPLE_SIDES_DEG = (0.0, 90.0, 180.0, 270.0)
PEOPLE_DISTANCES_M = (1.5, 3.0)
TURNED_CORNER_DEG = (30.0, 35.0, 40.0)


def people_poses() -> list[np.ndarray]:
    """True T_world_camera of the frames that look at the tour's people: each person from ``PEOPLE_SIDES_DEG``
    at ``PEOPLE_DISTANCES_M`` (the camera 0.3 m inside the site's outer walls at least), then the tour's first
    station (the south-west corner) turned ``TURNED_CORNER_DEG`` to the right."""
    from bim2rdt.perception.camera import look_at
    from bim2rdt.sim.tour import CAMERA_HEIGHT, PEOPLE_XY

    poses = []
    for px, py in PEOPLE_XY:
        for side in np.deg2rad(PEOPLE_SIDES_DEG):
            for distance in PEOPLE_DISTANCES_M:
                x, y = px + distance * np.cos(side), py + distance * np.sin(side)
                if 0.3 < x < 19.7 and 0.3 < y < 13.7:
                    poses.append(look_at((x, y, CAMERA_HEIGHT), (px, py, 0.9)))
    corner = tour_poses(1.0)[0]
    state, tilt = to_planar(corner)
    return poses + [from_planar(state - np.array([0.0, 0.0, 0.0, np.deg2rad(turn)]), tilt) for turn in TURNED_CORNER_DEG]


def run_people(out_dir: Path, seed: int = 0, cfg: GlobalSearchConfig | None = None) -> dict:
    """The frames of :func:`people_poses` searched alone with the whole-thing rule (``with``) and without it
    (``without``: ``thing_whole`` 0), each with the IMU's up: per frame its person share and both outcomes, and
    the counts over the frames with a person in view.

    Args:
        out_dir: Where the site's IFC is built (as the tour's).
        seed: Seed of the site's moved objects and the frames' noise.
        cfg: The search's settings; None: the defaults.

    Returns:
        JSON-able: ``frames`` (per frame), ``summary`` (``frames``, ``person_in_view``, and for ``with`` and
            ``without`` the successes, wrong-and-confident and refusals among the frames with a person in view).
    """
    from bim2rdt.perception.camera import Intrinsics
    from bim2rdt.sim.render import render_rgbd
    from bim2rdt.sim.scene import WORKER

    cfg = cfg or GlobalSearchConfig()
    without = cfg.model_copy(update={"thing_whole": 0.0})
    model = load_ifc(build_site_ifc(out_dir / "site.ifc"), cache_dir=out_dir / "cache")
    scene = tour_scene(model, seed=seed).scene
    rng = np.random.default_rng(seed)
    frames = []
    for T_true in people_poses():
        rendered = render_rgbd(scene, Intrinsics(), T_true, rng)
        hit = np.isfinite(rendered.depth)
        share = float((rendered.labels[hit] == WORKER).mean()) if hit.any() else 0.0
        frame = replace(rendered.as_frame(Intrinsics()), T_world_camera=None)
        up = T_true[:3, :3].T @ np.array([0.0, 0.0, 1.0])
        frames.append({"person_share": share, "with": _ours(frame, model, up, cfg, T_true, YAW_DEG),
                       "without": _ours(frame, model, up, without, T_true, YAW_DEG)})
    seen = [f for f in frames if f["person_share"] >= PERSON_SHARE]
    summary = {"frames": len(frames), "person_in_view": len(seen)}
    for name in ("with", "without"):
        summary[name] = {outcome: sum(f[name]["outcome"] == outcome for f in seen)
                         for outcome in ("success", "wrong", "refused")}
    return {"frames": frames, "summary": summary}
