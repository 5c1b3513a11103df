"""bim2rdt.planning: the robot's paths through the site, from the BIM and what the twin observed.

``OccupancyGrid.from_bim`` slices a storey's element meshes in the robot's height band (doors open or closed by
a policy, openings left free, where there is no floor blocked) and grows them by the robot's radius;
``with_obstacles`` puts in the objects the twin observed, ``with_zones`` the keep-out zones (the BIM's off-limits
zones, ``worker_keepouts`` around people); ``plan_path`` runs A* (pyastar2d) and smooths the result through free
space; ``plan_tour`` orders goals by path length; ``line_of_sight`` says whether walls hide a target from a
viewpoint and ``first_blocked_leg`` whether a path survived a change; ``Navigator`` walks paths on a clock and
replans when objects or zones block them; ``save_nav2`` writes the map for ROS map_server / Nav2.
"""

from bim2rdt.planning.errors import PlanningError
from bim2rdt.planning.frame import GridFrame
from bim2rdt.planning.grid import KEEPOUT_KINDS, STRUCTURE_KINDS, OccupancyGrid
from bim2rdt.planning.navigator import Leg, Navigator, Replan
from bim2rdt.planning.path import path_length, plan_path
from bim2rdt.planning.raster import Footprint
from bim2rdt.planning.sight import first_blocked_leg, line_of_sight, occluders
from bim2rdt.planning.tour import Tour, plan_tour
from bim2rdt.planning.viewpoints import pick_viewpoint, reachable
from bim2rdt.planning.zones import KeepOut, WorkerZones, activity_windows, worker_keepouts

__all__ = ["activity_windows", "first_blocked_leg", "Footprint", "GridFrame", "KeepOut", "KEEPOUT_KINDS", "Leg",
           "line_of_sight", "Navigator", "occluders", "OccupancyGrid", "path_length", "pick_viewpoint", "plan_path",
           "plan_tour", "PlanningError", "reachable", "Replan", "STRUCTURE_KINDS", "Tour", "worker_keepouts",
           "WorkerZones"]
