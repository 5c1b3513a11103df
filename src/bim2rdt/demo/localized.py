"""The mission's robot on drifting odometry: it drives to each planned station by what it believes, fixes its
pose on the BIM there (looking around when one view leaves a direction free), and hands the mission detections
placed with that estimate, never with the simulator's truth.

``LocalizedRobot`` is the mission's ``perceive(station, T_world_camera)``: ``T_world_camera`` is the planned
station, in the robot's belief. The robot commands the move from its estimate to the station; the simulated
robot carries it out exactly and its odometry reports it with drift. With ``anchored`` the station's frame is
fixed on the BIM and fused; without, the robot runs on dead reckoning alone (the comparison run). Each station's
record keeps what the report needs: the estimate, the fixes, the check shots, and (scored afterwards, from the
simulator) the true pose.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.localization import LocalizationConfig, OdometryNoise, PoseFilter, StationFix, Turned, localize_station
from bim2rdt.localization.checkshots import StationCheck, check_shots
from bim2rdt.localization.planar import between, from_planar, to_planar
from bim2rdt.mission import DirectRoute, run_mission
from bim2rdt.mission.route import Route
from bim2rdt.mission.records import MissionResult
from bim2rdt.perception.camera import Intrinsics, look_at
from bim2rdt.perception.detection import Detection
from bim2rdt.registration import IcpConfig
from bim2rdt.sim.building import building_parts
from bim2rdt.sim.reality import Reality
from bim2rdt.sim.render import render_rgbd
from bim2rdt.sim.robot import SimulatedRobot
from bim2rdt.sim.scene import SiteScene
from bim2rdt.sim.views import object_scene_points

DOCK_SIGMA = (0.01, np.deg2rad(0.1))
"""The robot leaves a surveyed dock: 1 cm and 0.1 degree (1 sigma)."""
TURN_ONLY = 0.3
"""A look after walking less than this (m) is a turn in place; the robot does not localize again for it."""


@dataclass
class StationLocalization:
    """One station of the mission: the planned pose, what the robot believed when it captured (``estimate``),
    the looks it took (each a :class:`~bim2rdt.localization.StationFix`), its check shots, and the true pose
    (the simulator's, for scoring only)."""

    index: int
    planned: np.ndarray
    estimate: np.ndarray
    truth: np.ndarray
    looks: list[StationFix] = field(default_factory=list)
    check: StationCheck = field(default_factory=StationCheck)

    @property
    def error(self) -> float:
        """Horizontal distance between the believed and the true camera position, m."""
        return float(np.linalg.norm(self.estimate[:2, 3] - self.truth[:2, 3]))


class LocalizedRobot:
    """The mission's ``perceive`` callable for a simulated robot that localizes on ``model`` (``anchored``) or
    runs on dead reckoning.

    The robot's depth frames (what it localizes on) show ``reality``'s objects inside the model's building. Its
    detections come from a render of ``reality``'s own scene from the same true pose: without the building when
    the reality has none, as the mission's perception had it before localization existed (it still sees objects
    through walls; the perception work owns making it cope with occlusion)."""

    def __init__(self, reality: Reality, model: BimModel, dock: np.ndarray, seed: int = 0, anchored: bool = True,
                 config: LocalizationConfig | None = None, intrinsics: Intrinsics = Intrinsics(),
                 min_pixels: int = 150, route=None):
        self.reality, self.model, self.anchored, self.route = reality, model, anchored, route
        self.config, self.intrinsics, self.min_pixels = config or LocalizationConfig(), intrinsics, min_pixels
        self.robot = SimulatedRobot(with_building(reality.scene, model), dock, seed, intrinsics)
        state, _ = to_planar(dock)
        self.filter = PoseFilter(state, np.diag([DOCK_SIGMA[0] ** 2] * 3 + [DOCK_SIGMA[1] ** 2]), OdometryNoise())
        self.stations: list[StationLocalization] = []
        self.rng = np.random.default_rng(seed + 7)

    def __call__(self, station: int, T_world_camera: np.ndarray) -> list[Detection]:
        """Go to ``T_world_camera`` (believed), fix the pose there if the robot walked, return the detections."""
        goal, tilt = to_planar(T_world_camera)
        walked = self._walk(station, goal, tilt)
        estimate = from_planar(self.filter.state, tilt)
        if walked > TURN_ONLY:  # a look before a leg is a turn in place: the last fix still holds
            estimate = self._localize(station, T_world_camera, tilt)
        view = render_rgbd(self.reality.scene, self.intrinsics, self.robot.T_world_camera, self.rng)
        return self._detections(replace(view, T_world_camera=estimate), station)

    def _walk(self, station: int, goal: np.ndarray, tilt: np.ndarray) -> float:
        """Walk the route's path to this station (believed waypoints, as planned), then to ``goal``; each move
        commanded from the robot's estimate, its odometry fed to the filter. Returns the metres walked."""
        path = getattr(self.route, "walked", {}).get(station) if self.route is not None else None
        waypoints = [] if path is None or len(path) < 2 or np.linalg.norm(path[-1] - goal[:2]) > 0.05 else path[1:-1]
        walked = 0.0
        for xy in waypoints:
            heading = np.arctan2(xy[1] - self.filter.state[1], xy[0] - self.filter.state[0])
            walked += self._move(np.r_[xy, goal[2], heading], tilt)
        return walked + self._move(goal, tilt)

    def _move(self, goal: np.ndarray, tilt: np.ndarray) -> float:
        reading = self.robot.drive(between(self.filter.state, goal), tilt)
        self.filter.predict(reading.increment, reading.distance, reading.turned)
        return reading.distance

    def _localize(self, station: int, planned: np.ndarray, tilt: np.ndarray) -> np.ndarray:
        """Fix the pose on the BIM (anchored) or keep dead reckoning; record the station. Returns the estimate."""
        frames = [self.robot.render()]
        record = StationLocalization(station, planned, np.eye(4), self.robot.T_world_camera.copy())
        if self.anchored:
            record.looks = localize_station(self.filter, self.model, frames[0].as_frame(self.intrinsics), tilt,
                                            self._turn(frames), self.config, turn_back=True)
        record.estimate = from_planar(self.filter.state, tilt)
        record.truth = self.robot.T_world_camera.copy()
        if self.anchored:
            record.check = check_shots(frames[-1].as_frame(self.intrinsics), self.model, record.estimate)
        self.stations.append(record)
        return record.estimate

    def _turn(self, frames: list):
        def turn(angle: float) -> Turned:
            _, tilt = to_planar(self.robot.T_world_camera)
            reading = self.robot.drive(np.array([0.0, 0.0, 0.0, angle]), tilt)
            frames.append(self.robot.render())
            return Turned(frames[-1].as_frame(self.intrinsics), reading.increment, reading.distance, reading.turned)
        return turn

    def _detections(self, view, station: int) -> list[Detection]:
        """The ideal detector's objects in the view, their corners placed with the robot's estimate (the
        frame's ``T_world_camera`` is the estimate here, not the truth)."""
        seen, pixels = np.unique(view.labels[view.labels >= 0], return_counts=True)
        return [Detection(self.reality.truth[index].family,
                          object_scene_points(view, self.intrinsics, int(index), self.rng), station)
                for index, count in zip(seen, pixels) if count >= self.min_pixels]


@dataclass
class MissionLocalization:
    """Both runs' robots: the mission on odometry + BIM fixes (its stations), and the same mission on dead
    reckoning alone (its result and stations), for the report to compare."""

    stations: list[StationLocalization]
    dead_reckoning: MissionResult
    dead_reckoning_stations: list[StationLocalization]


def dock_pose(stations: list[np.ndarray], start_xy, camera_height: float) -> np.ndarray:
    """The robot's surveyed start: its camera at ``start_xy``, level, facing the first station."""
    first = stations[0][:3, 3]
    if np.linalg.norm(first[:2] - np.asarray(start_xy, float)) < 1e-6:
        return stations[0].copy()
    return look_at((*start_xy, camera_height), (first[0], first[1], camera_height))


def localized_mission(targets, stations, reality: Reality, model: BimModel, priors, new_object_mesh,
                      mission_config, start_xy, seed: int = 0, icp: IcpConfig | None = None, tick=lambda: None,
                      route: Route | None = None,
                      comparison_route: Route | None = None) -> tuple[MissionResult, MissionLocalization]:
    """Run the mission on odometry + BIM localization (its verdicts go to the twin), then again on dead
    reckoning alone (for comparison only). ``route`` walks the first run and ``comparison_route`` (a fresh one:
    a route keeps what it walked) the second; None walks straight to each station."""
    icp = icp or IcpConfig()
    dock = dock_pose(stations, start_xy, mission_config.camera_height)
    anchored = LocalizedRobot(reality, model, dock, seed, anchored=True, route=route)
    mission = run_mission(targets, stations, anchored, priors, new_object_mesh, mission_config, icp, tick=tick,
                          route=route or DirectRoute())
    drifting = LocalizedRobot(reality, model, dock, seed, anchored=False, route=comparison_route)
    dead = run_mission(targets, stations, drifting, priors, new_object_mesh, mission_config, icp,
                       route=comparison_route or DirectRoute())
    return mission, MissionLocalization(anchored.stations, dead, drifting.stations)


def with_building(scene: SiteScene, model: BimModel) -> SiteScene:
    """``scene``'s objects and workers inside the model's building (its walls, slabs, columns and doors), on
    open ground; ``scene`` itself when it already has the building."""
    if scene.building:
        return scene
    return SiteScene(scene.objects, ground_size=max(scene.ground_size, 60.0), building=building_parts(model),
                     workers=scene.workers)

