"""The robot loop on any robot: walk to each station on odometry, capture, fix the pose on the BIM, detect, and
let the mission register and judge what was found (:func:`~bim2rdt.mission.run.run_mission`); the caller records
the result into the twin (:func:`~bim2rdt.mission.record.record_mission`).

The loop is typed on protocols, never on a simulator: a :class:`Robot` moves when told (and reports its
odometry) and captures :class:`~bim2rdt.perception.Frame` s; a :class:`Detect` reads one frame's detections. The
simulator is one robot among others (``demo`` wires :class:`bim2rdt.sim.robot.SimulatedRobot` and its camera in),
a driver for a real robot another. A frame's own ``T_world_camera`` (known, a prior, or absent) is never used: the
loop places every frame with its own estimate (odometry + BIM fixes; ``Frame.localized``), since that is all a real
robot knows.

:class:`LocalizedRobot` is the mission's ``perceive(station, T_world_camera)``: ``T_world_camera`` is the planned
station, in the robot's belief. It walks the route's path there from its estimate, and after a walk fixes the pose
on the frame it sees (``anchored``; without, it runs on dead reckoning alone: a comparison run), looking around
when one view leaves a direction free. Each fix is kept as a :class:`StationLocalization`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.localization import LocalizationConfig, OdometryNoise, PoseFilter, StationFix, Turned, localize_station
from bim2rdt.localization import StationCheck, check_shots
from bim2rdt.localization import between, from_planar, to_planar
from bim2rdt.mission.context import MissionContext
from bim2rdt.mission.records import MissionResult
from bim2rdt.mission.route import DirectRoute, Route
from bim2rdt.mission.run import run_mission
from bim2rdt.perception import Detection, Frame, look_at

DOCK_SIGMA = (0.01, np.deg2rad(0.1))
"""The robot leaves a surveyed dock: 1 cm and 0.1 degree (1 sigma)."""
TURN_ONLY = 0.3
"""A look after walking less than this (m) is a turn in place; the robot does not localize again for it."""


class Odometry(Protocol):
    """One move's odometry: ``increment`` (forward, left, up m, turn rad) in the heading frame of the move's start,
    the ``distance`` walked (m) and the angle ``turned`` (rad, absolute sum)."""

    increment: np.ndarray
    distance: float
    turned: float


class Robot(Protocol):
    """A robot that moves and captures frames. ``drive`` carries out a commanded move (forward, left, up m, turn
    rad, in its current heading frame; the camera's tilt set to ``R_level_camera``) and returns what its odometry
    measured; ``capture`` returns the frame its camera sees now; ``turn`` turns in place by an angle (rad, about
    the vertical, the camera's tilt kept), captures, and reports the frame and the turn's odometry (what
    :func:`~bim2rdt.localization.localize_station` asks for when one view leaves a direction free)."""

    def drive(self, increment: np.ndarray, R_level_camera: np.ndarray) -> Odometry:
        """Carry out a commanded move.

        Args:
            increment: (forward, left, up, turn): metres in the current heading frame, and radians.
            R_level_camera: (3,3) the camera's tilt to set: camera (OpenCV axes) to the levelled heading frame.

        Returns:
            What the odometry measured of the move.
        """
        ...

    def capture(self) -> Frame:
        """Capture what the camera sees now.

        Returns:
            The RGB-D frame (depth in metres).
        """
        ...

    def turn(self, angle: float) -> Turned:
        """Turn in place about the vertical (the camera's tilt kept) and capture.

        Args:
            angle: The turn, radians, counter-clockwise seen from above.

        Returns:
            The frame after the turn and the turn's odometry.
        """
        ...


class Detect(Protocol):
    """The detections (with world points) of ``station``'s ``frame``, the frame placed where the robot believes
    its camera was: :func:`bim2rdt.perception.locate_detections` with a detector, or a stand-in."""

    def __call__(self, station: int, frame: Frame) -> list[Detection]: ...


@dataclass
class StationLocalization:
    """One localized look of the mission: the planned pose, what the robot believed when it captured
    (``estimate``), which of the robot's captures (0-based, in order) was the station's view (``capture``: a
    caller that knows where the robot truly was can score the estimate), the looks it took (each a
    :class:`~bim2rdt.localization.StationFix`) and its check shots."""

    index: int
    planned: np.ndarray
    estimate: np.ndarray
    capture: int
    looks: list[StationFix] = field(default_factory=list)
    check: StationCheck = field(default_factory=StationCheck)


@dataclass
class RobotMission:
    """A robot's mission: the mission's ``result`` and the robot's localized looks (``stations``)."""

    result: MissionResult
    stations: list[StationLocalization]


class LocalizedRobot:
    """The mission's ``perceive`` callable for a ``robot`` that localizes on ``model`` (``anchored``) or runs on
    dead reckoning from ``dock`` (T_world_camera), walking ``route``'s paths when given; ``detect`` reads each
    station's frame.

    Args:
        robot: The robot that moves and captures.
        detect: Reads the detections of each station's frame.
        model: The BIM the robot localizes on.
        dock: ``T_world_camera`` (4x4, metres) of the robot's surveyed start.
        anchored: Localize on the BIM at each station; False runs on dead reckoning alone.
        config: Localization's settings; None uses the defaults.
        route: Paths to walk between stations; None goes straight to each.
    """

    def __init__(self, robot: Robot, detect: Detect, model: BimModel, dock: np.ndarray, anchored: bool = True,
                 config: LocalizationConfig | None = None, route: Route | None = None):
        self.robot, self.detect, self.model, self.anchored, self.route = robot, detect, model, anchored, route
        self.config = config or LocalizationConfig()
        state, _ = to_planar(dock)
        self.filter = PoseFilter(state, np.diag([DOCK_SIGMA[0] ** 2] * 3 + [DOCK_SIGMA[1] ** 2]), OdometryNoise())
        self.stations: list[StationLocalization] = []
        self.captures = 0
        self._latest: dict[int, Frame] = {}

    def __call__(self, station: int, T_world_camera: np.ndarray) -> list[Detection]:
        """Go to ``T_world_camera`` (believed), fix the pose there if the robot walked, return the detections."""
        goal, tilt = to_planar(T_world_camera)
        walked = self._walk(station, goal, tilt)
        frames = [self._capture()]
        if walked > TURN_ONLY:  # a look before a leg is a turn in place: the last fix still holds
            self._localize(station, T_world_camera, tilt, frames)
        frame = frames[-1].localized(from_planar(self.filter.state, tilt))
        self._latest[station] = frame
        return self.detect(station, frame)

    def station_frame(self, station: int) -> Frame | None:
        """The last frame detected in at a station, placed by the robot's estimate: the mission's ``frame_of``.

        Args:
            station: The station's index.

        Returns:
            The frame with the estimated ``T_world_camera``, or None before the robot got there.
        """
        return self._latest.get(station)

    def _capture(self) -> Frame:
        self.captures += 1
        return self.robot.capture()

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

    def _localize(self, station: int, planned: np.ndarray, tilt: np.ndarray, frames: list[Frame]) -> None:
        """Fix the pose on the BIM (anchored; looking around and back when needed) or keep dead reckoning, and
        record the look; ``frames`` ends with the frame facing the station's view."""
        record = StationLocalization(station, planned, np.eye(4), -1)
        if self.anchored:
            record.looks = localize_station(self.filter, self.model, frames[0], tilt, self._turn(frames),
                                            self.config, turn_back=True)
        record.estimate = from_planar(self.filter.state, tilt)
        record.capture = self.captures - 1
        if self.anchored:
            record.check = check_shots(frames[-1], self.model, record.estimate)
        self.stations.append(record)

    def _turn(self, frames: list[Frame]) -> Callable[[float], Turned]:
        def turn(angle: float) -> Turned:
            turned = self.robot.turn(angle)
            self.captures += 1
            frames.append(turned.frame)
            return turned
        return turn


def dock_pose(stations: Sequence[np.ndarray], start_xy: np.ndarray | tuple[float, float],
              camera_height: float) -> np.ndarray:
    """The robot's surveyed start: its camera level, facing the first station.

    Args:
        stations: ``T_world_camera`` (4x4, metres) of each station.
        start_xy: World (x, y) of the start, metres.
        camera_height: World height of the camera, metres.

    Returns:
        ``T_world_camera`` (4x4) at the start; the first station's pose when the start is there.
    """
    first = stations[0][:3, 3]
    if np.linalg.norm(first[:2] - np.asarray(start_xy, float)) < 1e-6:
        return stations[0].copy()
    return look_at((*start_xy, camera_height), (first[0], first[1], camera_height))


def run_robot_mission(context: MissionContext, robot: Robot, detect: Detect, dock: np.ndarray,
                      anchored: bool = True, route: Route | None = None) -> RobotMission:
    """The mission of ``context`` with ``robot`` leaving ``dock`` (T_world_camera), localizing on the BIM
    (``anchored``) or on dead reckoning alone, walking ``route`` (None: straight to each station); ``detect``
    reads each station's frame, and that frame (depth, intrinsics, the estimated pose) decides missing elements.

    Args:
        context: The mission: targets, stations, model, priors and settings.
        robot: The robot that moves and captures.
        detect: Reads the detections of each station's frame.
        dock: ``T_world_camera`` (4x4, metres) of the robot's surveyed start.
        anchored: Localize on the BIM at each station; False runs on dead reckoning alone.
        route: Paths to walk between stations; None goes straight to each.

    Returns:
        The mission's result and the robot's localized looks.
    """
    context = context.with_building()
    looking = LocalizedRobot(robot, detect, context.model, dock, anchored, context.localization, route)
    result = run_mission(context, looking, route or DirectRoute(), looking.station_frame)
    return RobotMission(result, looking.stations)
