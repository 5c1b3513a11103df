"""The localization tour: walk the embedded site on drifting odometry, fix every station's frame on the BIM, fuse,
and score dead reckoning, the BIM fixes, the fused estimate and the Open3D peer against the truth.

The truth (the tour's poses) is read here only to render frames, drive the simulated odometry and score; the
localizer and the filter see frames, odometry readings and the IMU's tilt. Times are the process's CPU time (one
core when pinned), per frame.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bim2rdt.bench.localization.peers import WHOLE_BIM_SPACING
from bim2rdt.bim import BimModel, load_ifc
from bim2rdt.localization import LocalizationConfig, OdometryNoise, PoseFilter, localize_station
from bim2rdt.localization.checkshots import check_shots
from bim2rdt.localization.planar import compose, from_planar, to_planar, wrap
from bim2rdt.localization.surfaces import permanent_map
from bim2rdt.sim.robot import SimulatedRobot
from bim2rdt.sim.site import build_site_ifc
from bim2rdt.sim.tour import tour_poses, tour_scene

AS_BUILT_TOLERANCE = 0.01
"""Walls, columns and slab stand this far off the BIM (1 sigma per axis, m): DIN 18202-class setting-out."""
DOCK_SIGMA = (0.01, np.deg2rad(0.1))
"""The robot starts at its surveyed dock: 1 cm and 0.1 degree (1 sigma)."""


@dataclass(frozen=True)
class PoseError:
    """Camera position error (m; its horizontal part and height apart too) and yaw error (deg, signed) against
    the truth."""

    position: float
    yaw_deg: float
    horizontal: float = 0.0
    height: float = 0.0


@dataclass
class Station:
    """One station of the tour, scored. ``fix`` (the station's first frame) is None when the frame was refused
    (``reason`` says why) or the fix was gated; ``fix_across`` is its position error across the directions it
    constrains. ``looks`` counts frames (more than one when the robot looked around), ``fused_first_look`` is the
    estimate after the first frame alone, ``fused`` after all of them. ``frame_seconds`` is each look's CPU time
    (localize and fuse; the robot's turn and capture excluded), ``fix_seconds`` the slowest of them."""

    index: int
    walked: float
    dead_reckoning: PoseError
    prior: PoseError
    fix: PoseError | None
    fix_across: float | None
    degenerate: int
    reason: str | None
    fix_seconds: float
    fused: PoseError
    check_residual: float
    check_flagged: bool
    check_shots: list[tuple[str, float, float]] = field(default_factory=list)
    peers: dict[str, tuple[PoseError, float]] = field(default_factory=dict)
    looks: int = 1
    fused_first_look: PoseError | None = None
    frame_seconds: list[float] = field(default_factory=list)


@dataclass
class LocalizationRun:
    """Every station of one tour, and the settings it ran with."""

    seed: int
    stations: list[Station]
    config: LocalizationConfig
    peers: list[str]
    tolerance: float = 0.0


def pose_error(T_est: np.ndarray, T_true: np.ndarray) -> PoseError:
    a, _ = to_planar(T_est)
    b, _ = to_planar(T_true)
    error = T_est[:3, 3] - T_true[:3, 3]
    return PoseError(float(np.linalg.norm(error)), float(np.rad2deg(wrap(a[3] - b[3]))),
                     float(np.linalg.norm(error[:2])), float(error[2]))


def _across(fix, T_true: np.ndarray) -> float:
    """Position error with the components along the fix's free directions removed."""
    error = fix.pose[:3, 3] - T_true[:3, 3]
    for direction in fix.degenerate:
        error = error - (error @ direction) * direction
    return float(np.linalg.norm(error))


def run_tour(out_dir: Path, seed: int = 0, distance: float = 100.0, config: LocalizationConfig | None = None,
             peers: list | None = None, tick: Callable[[], None] = lambda: None,
             tolerance: float = AS_BUILT_TOLERANCE) -> LocalizationRun:
    """Build the embedded site into ``out_dir``, walk ``distance`` m of the tour and score every station. The
    building stands off its BIM by ``tolerance`` (see :func:`~bim2rdt.sim.tour.tour_scene`)."""
    cfg = config or LocalizationConfig()
    model = load_ifc(build_site_ifc(Path(out_dir) / "site.ifc"), cache_dir=Path(out_dir) / "cache")
    poses = tour_poses(distance)
    robot = SimulatedRobot(tour_scene(model, seed=seed, tolerance=tolerance).scene, poses[0], seed)
    start, _ = to_planar(poses[0])
    dock = np.diag([DOCK_SIGMA[0] ** 2] * 3 + [DOCK_SIGMA[1] ** 2])
    tour = _Tour(model, PoseFilter(start, dock, OdometryNoise()), start.copy(), cfg, peers or [],
                 permanent_map(model).samples(WHOLE_BIM_SPACING) if peers else None)
    stations, walked = [], 0.0
    for index, target in enumerate(poses):
        if index:
            walked += float(np.linalg.norm(target[:2, 3] - robot.T_world_camera[:2, 3]))
            tour.moved(robot.walk_to(target))
        stations.append(tour.station(index, walked, robot))
        tick()
    return LocalizationRun(seed, stations, cfg, [peer.name for peer in peers or []], tolerance)


@dataclass
class _Tour:
    """What the tour carries from station to station: the model, the filter, dead reckoning, settings, peers."""

    model: BimModel
    pose_filter: PoseFilter
    dead: np.ndarray
    cfg: LocalizationConfig
    peers: list
    whole: tuple[np.ndarray, np.ndarray] | None

    def moved(self, reading) -> None:
        """Odometry of a leg or turn: dead reckoning integrates it, the filter predicts with it."""
        self.dead = compose(self.dead, reading.increment)
        self.pose_filter.predict(reading.increment, reading.distance, reading.turned)

    def station(self, index: int, walked: float, robot: SimulatedRobot) -> Station:
        """Capture, run the peers on the first frame, localize (looking around when needed), score."""
        first_truth = robot.T_world_camera.copy()
        _, tilt = to_planar(first_truth)
        prior = from_planar(self.pose_filter.state, tilt)
        frames = [robot.capture()]
        peers = {peer.name: _run_peer(peer, frames[0], self.model, self.whole, prior, first_truth)
                 for peer in self.peers}
        clock = _FrameClock()
        looks = localize_station(self.pose_filter, self.model, frames[0], tilt, self._turner(robot, frames, clock),
                                 self.cfg)
        seconds = clock.stop()
        fix = looks[0].fix if looks[0].applied else None
        after_first = from_planar(to_planar(looks[0].prior)[0] + looks[0].correction, tilt)
        truth, believed = robot.T_world_camera, from_planar(self.pose_filter.state, tilt)
        check = check_shots(frames[-1], self.model, believed)
        return Station(
            index=index, walked=walked, dead_reckoning=pose_error(from_planar(self.dead, tilt), truth),
            prior=pose_error(prior, first_truth), fix=pose_error(fix.pose, first_truth) if fix else None,
            fix_across=_across(fix, first_truth) if fix else None, degenerate=len(fix.degenerate) if fix else 0,
            reason=looks[0].reason, fix_seconds=max(seconds), frame_seconds=seconds, fused=pose_error(believed, truth),
            check_residual=check.residual, check_flagged=check.flagged,
            check_shots=[(shot.landmark.name, shot.residual, shot.tape) for shot in check.shots], peers=peers,
            looks=len(looks), fused_first_look=pose_error(after_first, first_truth))

    def _turner(self, robot: SimulatedRobot, frames: list, clock: _FrameClock):
        """The robot's turn for a look-around: dead reckoning integrates it too; its frame is kept; the clock
        leaves the turn and the capture out of the frames' time."""
        if not self.cfg.look_around_deg:
            return None

        def turn(angle: float):
            clock.lap()
            turned = robot.turn(angle)
            self.dead = compose(self.dead, turned.increment)
            frames.append(turned.frame)
            clock.start()
            return turned

        return turn


class _FrameClock:
    """CPU time of each frame a station localizes: started before the first, lapped when the robot turns for
    another look (the turn and its capture are the robot's, not the localizer's), started again after it."""

    def __init__(self):
        self.laps: list[float] = []
        self.start()

    def start(self) -> None:
        self.started = time.process_time()

    def lap(self) -> None:
        self.laps.append(time.process_time() - self.started)

    def stop(self) -> list[float]:
        self.lap()
        return self.laps


def _run_peer(peer, frame, model, whole, prior, truth) -> tuple[PoseError, float]:
    started = time.process_time()
    pose = peer(frame, permanent_map(model), whole, prior)
    return pose_error(pose, truth), time.process_time() - started
