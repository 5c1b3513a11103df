"""The robot mission: plan stations -> capture -> perceive -> associate -> register -> verdict.

``stations`` plans where the robot looks from, ``route`` where it can stand and see (on the BIM's map), in which
order and how it walks there, ``association`` ties detections to BIM elements, ``fitting`` registers each object
with SG-ICP (perception's one fitting path), ``explained`` sets aside a fit whose points another element's surface
explains, ``verdict`` judges it against the BIM, ``run`` is the mission over detections, and ``robot`` the robot
loop (walk, capture, localize, detect) on any :class:`Robot` and :class:`Detect`, the simulator being one."""

from bim2rdt.mission.config import MissionConfig
from bim2rdt.mission.explained import KnownSurface, building_surfaces
from bim2rdt.mission.record import record_mission
from bim2rdt.mission.records import MissingElement, MissionResult, Observation, Target
from bim2rdt.mission.robot import (Detect, LocalizedRobot, MissionContext, Robot, RobotMission, StationLocalization,
                                   dock_pose, run_robot_mission)
from bim2rdt.mission.route import DirectRoute, PlannedRoute, RoutePlan, plan_route
from bim2rdt.mission.run import run_mission
from bim2rdt.mission.stations import plan_stations
from bim2rdt.mission.verdict import pose_delta

__all__ = ["Detect", "DirectRoute", "KnownSurface", "LocalizedRobot", "MissingElement", "MissionConfig",
           "MissionContext", "MissionResult", "Observation", "PlannedRoute", "Robot", "RobotMission", "RoutePlan",
           "StationLocalization", "Target", "building_surfaces", "dock_pose", "plan_route", "plan_stations",
           "pose_delta", "record_mission", "run_mission", "run_robot_mission"]
