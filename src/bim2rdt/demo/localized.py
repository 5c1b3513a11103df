"""The mission's robot on drifting odometry: it drives to each planned station by what it believes, fixes its
pose on the BIM there (looking around when one view leaves a direction free), and hands the mission detections
placed with that estimate, never with the simulator's truth.

``LocalizedRobot`` is the mission's ``perceive(station, T_world_camera)``: ``T_world_camera`` is the planned
station, in the robot's belief. The robot walks the route's path from its estimate (the simulated robot carries
each commanded move out exactly and its odometry reports it with drift), and after a walk fixes the pose on the
frame it sees (with ``anchored``; without, it runs on dead reckoning alone: the comparison run). The camera and
the detector are the demo's (``render(T_true)`` and ``detect(station, frame, T_believed)``, see
:mod:`bim2rdt.demo.perceivers`). Each station's record keeps what the report needs: the estimate, the fixes, the
check shots, and (scored afterwards, from the simulator) the true pose.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.localization import LocalizationConfig, OdometryNoise, PoseFilter, StationFix, Turned, localize_station
from bim2rdt.localization.checkshots import StationCheck, check_shots
from bim2rdt.localization.planar import between, from_planar, to_planar
from bim2rdt.mission import DirectRoute, building_surfaces, run_mission
from bim2rdt.mission.records import MissionResult
from bim2rdt.mission.route import Route
from bim2rdt.perception.camera import Intrinsics, look_at
from bim2rdt.perception.detection import Detection
from bim2rdt.perception.frame import Frame
from bim2rdt.registration import IcpConfig
from bim2rdt.twin import TolerancePolicy
from bim2rdt.sim.render import RgbdFrame
from bim2rdt.sim.robot import SimulatedRobot

DOCK_SIGMA = (0.01, np.deg2rad(0.1))
"""The robot leaves a surveyed dock: 1 cm and 0.1 degree (1 sigma)."""
TURN_ONLY = 0.3
"""A look after walking less than this (m) is a turn in place; the robot does not localize again for it."""


class Eyes(Protocol):
    """The camera and the detector: ``render`` a frame from where the camera truly is, ``detect`` the objects in
    it placed from where the robot believes it is."""

    intrinsics: Intrinsics

    def render(self, T_world_camera: np.ndarray) -> RgbdFrame: ...

    def detect(self, station: int, rendered: RgbdFrame, T_world_camera: np.ndarray) -> list[Detection]: ...

    def station_frame(self, station: int) -> Frame | None: ...


@dataclass
class StationLocalization:
    """One localized look of the mission: the planned pose, what the robot believed when it captured
    (``estimate``), the looks it took (each a :class:`~bim2rdt.localization.StationFix`), its check shots, and
    the true pose (the simulator's, for scoring only)."""

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
    """The mission's ``perceive`` callable for a simulated robot with ``eyes`` that localizes on ``model``
    (``anchored``) or runs on dead reckoning, walking ``route``'s paths when given."""

    def __init__(self, eyes: Eyes, model: BimModel, dock: np.ndarray, seed: int = 0, anchored: bool = True,
                 config: LocalizationConfig | None = None, route: Route | None = None):
        self.eyes, self.model, self.anchored, self.route = eyes, model, anchored, route
        self.config, self.intrinsics = config or LocalizationConfig(), eyes.intrinsics
        self.robot = SimulatedRobot(None, dock, seed, eyes.intrinsics, renderer=eyes.render)
        state, _ = to_planar(dock)
        self.filter = PoseFilter(state, np.diag([DOCK_SIGMA[0] ** 2] * 3 + [DOCK_SIGMA[1] ** 2]), OdometryNoise())
        self.stations: list[StationLocalization] = []

    def __call__(self, station: int, T_world_camera: np.ndarray) -> list[Detection]:
        """Go to ``T_world_camera`` (believed), fix the pose there if the robot walked, return the detections."""
        goal, tilt = to_planar(T_world_camera)
        walked = self._walk(station, goal, tilt)
        frames = [self.robot.render()]
        if walked > TURN_ONLY:  # a look before a leg is a turn in place: the last fix still holds
            self._localize(station, T_world_camera, tilt, frames)
        return self.eyes.detect(station, frames[-1], from_planar(self.filter.state, tilt))

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

    def _localize(self, station: int, planned: np.ndarray, tilt: np.ndarray, frames: list[RgbdFrame]) -> None:
        """Fix the pose on the BIM (anchored; looking around and back when needed) or keep dead reckoning, and
        record the look; ``frames`` ends with the frame facing the station's view."""
        record = StationLocalization(station, planned, np.eye(4), self.robot.T_world_camera.copy())
        if self.anchored:
            record.looks = localize_station(self.filter, self.model, frames[0].as_frame(self.intrinsics), tilt,
                                            self._turn(frames), self.config, turn_back=True)
        record.estimate = from_planar(self.filter.state, tilt)
        record.truth = self.robot.T_world_camera.copy()
        if self.anchored:
            record.check = check_shots(frames[-1].as_frame(self.intrinsics), self.model, record.estimate)
        self.stations.append(record)

    def _turn(self, frames: list[RgbdFrame]) -> Callable[[float], Turned]:
        def turn(angle: float) -> Turned:
            _, tilt = to_planar(self.robot.T_world_camera)
            reading = self.robot.drive(np.array([0.0, 0.0, 0.0, angle]), tilt)
            frames.append(self.robot.render())
            return Turned(frames[-1].as_frame(self.intrinsics), reading.increment, reading.distance, reading.turned)
        return turn


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


def localized_mission(targets, stations, model: BimModel, eyes: Callable[[], Eyes], priors, new_object_mesh,
                      mission_config, start_xy, seed: int = 0, icp: IcpConfig | None = None, tick=lambda: None,
                      route: Route | None = None,
                      comparison_route: Route | None = None,
                      tolerances: TolerancePolicy | None = None) -> tuple[MissionResult, MissionLocalization]:
    """Run the mission on odometry + BIM localization (its verdicts go to the twin), then again on dead
    reckoning alone (for comparison only). ``eyes()`` makes each run's camera and detector; ``route`` walks the
    first run and ``comparison_route`` (a fresh one: a route keeps what it walked) the second; None walks
    straight to each station. Each run reads the frames its ``eyes`` detected in (``station_frame``) for
    missing elements, and judges by ``tolerances`` (the twin's presets)."""
    icp = icp or IcpConfig()
    dock = dock_pose(stations, start_xy, mission_config.camera_height)
    building = building_surfaces(model)
    anchored = LocalizedRobot(eyes(), model, dock, seed, anchored=True, route=route)
    mission = run_mission(targets, stations, anchored, priors, new_object_mesh, mission_config, icp, tick=tick,
                          route=route or DirectRoute(), frame_of=anchored.eyes.station_frame, tolerances=tolerances,
                          building=building)
    drifting = LocalizedRobot(eyes(), model, dock, seed, anchored=False, route=comparison_route)
    dead = run_mission(targets, stations, drifting, priors, new_object_mesh, mission_config, icp,
                       route=comparison_route or DirectRoute(), frame_of=drifting.eyes.station_frame,
                       tolerances=tolerances, building=building)
    return mission, MissionLocalization(anchored.stations, dead, drifting.stations)
