"""The demo's robot: the simulator wired into the library's robot loop (:mod:`bim2rdt.mission.robot`).

The robot is a :class:`~bim2rdt.sim.robot.SimulatedRobot` on drifting odometry whose camera is the demo's
(:class:`~bim2rdt.demo.perceivers.DemoPerception`: the building, RGB, time-of-flight artefacts, workers), and its
``detect`` is the demo's detector. The loop drives it by what it believes, fixes its pose on the BIM, and hands the
mission detections placed with that estimate, never with the simulator's truth. The truth comes back only here,
afterwards: each localized look is scored against where the simulated camera truly was when it captured.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from bim2rdt.demo.perceivers import DemoPerception
from bim2rdt.localization import StationFix
from bim2rdt.localization.checkshots import StationCheck
from bim2rdt.mission.records import MissionResult
from bim2rdt.mission.robot import MissionContext, StationLocalization, dock_pose, run_robot_mission
from bim2rdt.mission.route import Route
from bim2rdt.sim.robot import SimulatedRobot


@dataclass
class ScoredStation:
    """One localized look of the mission (``located``) and the simulator's true camera pose when the robot
    captured the station's view (``truth``, for scoring only)."""

    located: StationLocalization
    truth: np.ndarray

    @property
    def index(self) -> int:
        return self.located.index

    @property
    def planned(self) -> np.ndarray:
        return self.located.planned

    @property
    def estimate(self) -> np.ndarray:
        return self.located.estimate

    @property
    def looks(self) -> list[StationFix]:
        return self.located.looks

    @property
    def check(self) -> StationCheck:
        return self.located.check

    @property
    def error(self) -> float:
        """Horizontal distance between the believed and the true camera position, m."""
        return float(np.linalg.norm(self.estimate[:2, 3] - self.truth[:2, 3]))


@dataclass
class MissionLocalization:
    """Both runs' robots: the mission on odometry + BIM fixes (its stations), and the same mission on dead
    reckoning alone (its result and stations), for the report to compare."""

    stations: list[ScoredStation]
    dead_reckoning: MissionResult
    dead_reckoning_stations: list[ScoredStation]


def localized_mission(context: MissionContext, eyes: Callable[[], DemoPerception], start_xy, seed: int = 0,
                      route: Route | None = None, comparison_route: Route | None = None,
                      record: Callable | None = None) -> tuple[MissionResult, MissionLocalization]:
    """Run ``context``'s mission with a simulated robot docked at ``start_xy`` on odometry + BIM localization (its
    verdicts go to the twin), then again on dead reckoning alone (for comparison only; without ``context.tick``).
    ``eyes()`` makes each run's camera and detector; ``route`` walks the first run and ``comparison_route`` (a
    fresh one: a route keeps what it walked) the second; None walks straight to each station. ``record(robot,
    dock)``, when given, wraps the first run's robot (``demo --record``: a bag of what it measured)."""
    context = context.with_building()
    dock = dock_pose(context.stations, start_xy, context.config.camera_height)
    mission, anchored = _simulated(context, eyes(), dock, seed, True, route, record)
    dead, drifting = _simulated(replace(context, tick=lambda: None), eyes(), dock, seed, False, comparison_route)
    return mission, MissionLocalization(anchored, dead, drifting)


def _simulated(context: MissionContext, eyes: DemoPerception, dock: np.ndarray, seed: int, anchored: bool,
               route: Route | None, record: Callable | None = None) -> tuple[MissionResult, list[ScoredStation]]:
    """One run of the library's loop on a simulated robot whose camera is ``eyes``; its looks scored."""
    robot = SimulatedRobot(None, dock, seed, eyes.intrinsics, renderer=eyes.render)
    driven = robot if record is None else record(robot, dock)
    run = run_robot_mission(context, driven, eyes.detect_frame, dock, anchored, route)
    return run.result, [ScoredStation(s, robot.captured[s.capture]) for s in run.stations]
