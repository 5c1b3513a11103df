"""The robot's route: where it stands to see each object, in which order it goes, and how it gets there.

- **Stations** (``plan_route``): for each object, viewpoints are proposed best first (across its long side,
  facing the site's interior, as :mod:`bim2rdt.mission.stations` prefers them, at the standoff, nearer and
  farther; then all around), and the first one the robot can stand on, reach from its dock, and see the object from over the
  walls is taken. An object with none is reported, not visited.
- **Order**: the tour goes by the length of the planned paths (``planning.plan_tour``), not straight lines.
- **Walking** (``PlannedRoute``, the mission's route strategy): the robot walks the planned legs with a
  ``planning.Navigator``. Before each leg it looks along it, and at each station it looks at its object; what
  it sees that the map does not explain (an unplanned drum, a crate pushed into the aisle) is located at once
  (``locate``: the mission's own SG-ICP fit) and goes into the map, so the legs are checked against it and
  replanned if blocked; workers' keep-out zones change on the navigator's clock. Look-ahead frames only steer
  the robot: the verdicts come from the stations' frames. A station it cannot reach is moved to another viewpoint
  of its object; failing that the robot waits (up to ``MAX_WAIT_S``) for a zone to clear; failing that it is
  skipped with the reason.

``DirectRoute`` is the stand-in without a map: stations as given, no walking.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import trimesh
from scipy import ndimage

from bim2rdt.mission.config import MissionConfig
from bim2rdt.mission.records import Observation, Target
from bim2rdt.mission.stations import nearly, station_pose, view_directions
from bim2rdt.perception import Detection, look_at
from bim2rdt.planning import Navigator, OccupancyGrid, PlanningError, Replan, pick_viewpoint, plan_tour, reachable

AROUND = 12
"""Extra view directions tried all around an object when the four preferred ones fail."""
SCALES = (1.0, 0.75, 1.4)
"""Standoffs tried, as multiples of the mission's standoff."""
EXPLAINED_MARGIN = 0.2
"""A detection's points within this of the map's occupied cells are explained by the map, m."""
DWELL_S = 15.0
"""Seconds the robot stands at a station to capture."""
MAX_WAIT_S = 120.0
"""Longest the robot waits for a worker's zone to clear from a station it cannot reach, s."""
LOOK_AHEAD = 3.0
"""Before each leg the robot looks this far along it (m), at the height objects stand."""

Locate = Callable[[Detection], tuple[Observation, trimesh.Trimesh]]
"""The mission's fit of one detection: (its observation, the mesh it was fitted with)."""


@dataclass
class RoutePlan:
    """Stations (T_world_camera) in visiting order, the GlobalId each looks at, the planned path to each (from
    the dock or the station before), every station's viewpoints best first (the chosen one first), and the
    objects no viewpoint serves {GlobalId: why}."""

    stations: list[np.ndarray]
    targets: list[Target]
    legs: list[np.ndarray]
    candidates: list[list[np.ndarray]]
    unplaced: dict[str, str] = field(default_factory=dict)


def plan_route(targets: Sequence[Target], start_xy: np.ndarray | tuple[float, float], grid: OccupancyGrid,
               config: MissionConfig) -> RoutePlan:
    """One reachable station with a line of sight per target, in the order of the shortest walk.

    Args:
        targets: The BIM objects to look at.
        start_xy: World (x, y) of the dock, metres.
        grid: The occupancy grid the robot walks on.
        config: Standoff and camera height of the stations.

    Returns:
        The stations (``T_world_camera``) in visiting order with their targets, the planned path to each, every
            station's viewpoints best first, and {GlobalId: why} of the targets no viewpoint serves.
    """
    region = reachable(grid, start_xy)
    centre = np.mean([t.placement[:2, 3] for t in targets], axis=0)
    chosen, unplaced = [], {}
    for target in targets:
        poses = viewpoint_poses(target, centre, config)
        where = target.placement[:2, 3]
        pick = pick_viewpoint(grid, where, [T[:2, 3] for T in poses], region, ignore=[target.global_id])
        if pick is None:
            unplaced[target.global_id] = (f"{target.family}: no free, reachable viewpoint with a line of sight "
                                          f"within {SCALES[-1] * config.standoff:.1f} m")
            continue
        chosen.append((target, [poses[pick]] + poses[:pick] + poses[pick + 1:]))
    tour = plan_tour(grid, start_xy, [poses[0][:2, 3] for _, poses in chosen])
    for index, why in tour.unreachable.items():
        unplaced[chosen[index][0].global_id] = why
    ordered = [chosen[index] for index in tour.order]
    return RoutePlan([poses[0] for _, poses in ordered], [target for target, _ in ordered], tour.legs,
                     [poses for _, poses in ordered], unplaced)


def viewpoint_poses(target: Target, centre: np.ndarray, config: MissionConfig) -> list[np.ndarray]:
    """Camera poses looking at ``target``, best first: the four preferred directions (across the long side) at
    each of the ``SCALES`` of the standoff, then ``AROUND`` more directions (end-on views of a beam cannot tell
    where along its length it lies, so they come last)."""
    towards = centre - target.placement[:2, 3]
    preferred = view_directions(target, towards)
    angles = np.linspace(0.0, 2 * np.pi, AROUND, endpoint=False)
    around = sorted((np.array([np.cos(a), np.sin(a)]) for a in angles), key=lambda d: -nearly(float(d @ towards)))
    return [station_pose(target, view, config, scale) for views in (preferred, around) for scale in SCALES
            for view in views]


Look = Callable[[np.ndarray], list[Detection]]
"""The robot's camera and detector: detections from a frame taken at a camera pose (T_world_camera)."""


class Route(Protocol):
    """How the mission gets to its stations (a strategy: ``DirectRoute`` or ``PlannedRoute``)."""

    def reach(self, index: int, T_world_camera: np.ndarray, look: Look, locate: Locate) -> np.ndarray | None:
        """Go to station ``index`` (``look`` and ``locate`` let it see on the way); the camera pose actually
        taken, or None if it cannot be reached."""

    def seen(self, index: int, detections: list[Detection], locate: Locate) -> None:
        """What station ``index`` saw."""


class DirectRoute:
    """No map: every station as given, nothing walked."""

    def reach(self, index: int, T_world_camera: np.ndarray, look: Look, locate: Locate) -> np.ndarray | None:
        """Take the station as given.

        Args:
            index: The station's index.
            T_world_camera: The station's camera pose (4x4, metres).
            look: Unused: nothing is seen on the way.
            locate: Unused.

        Returns:
            ``T_world_camera``.
        """
        return T_world_camera

    def seen(self, index: int, detections: list[Detection], locate: Locate) -> None:
        """Ignore what a station saw: there is no map to put it in.

        Args:
            index: The station's index.
            detections: What it saw.
            locate: Unused.
        """
        return None


@dataclass
class Located:
    """An object placed in the robot's map from one view (the twin's per-element state, duck-typed)."""

    global_id: str | None
    family: str
    pose: np.ndarray
    status: str
    mesh: tuple[np.ndarray, np.ndarray] | None


class PlannedRoute:
    """Walks ``plan`` with ``navigator`` (start it at the dock, on the shift's clock), standing ``dwell_s`` at
    each station. Afterwards ``walked`` has the path walked to each station, ``arrivals`` when it got there
    (the navigator's clock), ``skipped`` {station: why},
    ``located`` the objects put into the map, and ``navigator.replans`` every replan.

    Args:
        plan: The route to walk.
        navigator: Walks the robot and replans as the map changes.
        camera_height: World height of the camera, metres.
        dwell_s: How long the robot stands at each station, seconds.
    """

    def __init__(self, plan: RoutePlan, navigator: Navigator, camera_height: float, dwell_s: float = DWELL_S) -> None:
        self.plan, self.navigator, self.camera_height, self.dwell_s = plan, navigator, camera_height, dwell_s
        self.walked: dict[int, np.ndarray] = {}
        self.arrivals: dict[int, float] = {}
        self.skipped: dict[int, str] = {}
        self.located: dict[str, Located] = {}

    def reach(self, index: int, T_world_camera: np.ndarray, look: Look, locate: Locate) -> np.ndarray | None:
        """Look ahead along the planned leg (what it shows goes into the map, so the leg is checked against it),
        then walk it; a station that cannot be reached now is swapped for another viewpoint, or waited for
        while keep-out zones change.

        Args:
            index: The station's index.
            T_world_camera: The station's planned camera pose (4x4, metres).
            look: Takes a frame at a camera pose and returns its detections.
            locate: Registers a detection into an observation and its mesh.

        Returns:
            The camera pose actually taken, or None if the station cannot be reached.
        """
        goal = T_world_camera[:2, 3]
        self.seen(index, look(self._ahead(self.plan.legs[index], goal)), locate)
        try:
            self.walked[index] = self.navigator.go(goal, self.plan.legs[index])
            taken = T_world_camera
        except PlanningError as error:
            taken = self._another_viewpoint(index, str(error))
            taken = taken if taken is not None else self._wait_for_zones(index, T_world_camera, str(error))
            if taken is None:
                self.skipped[index] = str(error)
        if taken is not None:
            self.arrivals[index] = self.navigator.time
            self.navigator.wait(self.dwell_s)
        return taken

    def seen(self, index: int, detections: list[Detection], locate: Locate) -> None:
        """Put the objects a look found into the robot's map (those the map does not explain yet).

        Args:
            index: The station's index.
            detections: What the look saw.
            locate: Registers a detection into an observation and its mesh.
        """
        explained = self._explained()
        for detection in detections:
            if self._unexplained(detection, explained):
                observation, mesh = locate(detection)
                key = observation.global_id or f"new-{len(self.located) + 1}"
                self.located[key] = Located(observation.global_id, observation.family, observation.pose,
                                            str(observation.status),
                                            None if observation.global_id else (mesh.vertices, mesh.faces))
                self.navigator.observe(self.located)
                explained = self._explained()

    def _ahead(self, leg: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """A camera pose at the robot, looking ``LOOK_AHEAD`` m along where it is about to walk."""
        here = self.navigator.position
        towards = leg[1] if np.allclose(leg[0], here) and len(leg) > 1 else goal
        heading = (towards - here) / max(float(np.linalg.norm(towards - here)), 1e-9)
        return look_at(np.r_[here, self.camera_height], np.r_[here + LOOK_AHEAD * heading, 0.35])

    def _another_viewpoint(self, index: int, why: str) -> np.ndarray | None:
        """The first other viewpoint of the station's object the robot can reach and see it from now."""
        navigator, target = self.navigator, self.plan.targets[index]
        others = self.plan.candidates[index][1:]
        pick = pick_viewpoint(navigator.grid, target.placement[:2, 3], [T[:2, 3] for T in others],
                              reachable(navigator.grid, navigator.position), ignore=[target.global_id])
        if pick is None:
            return None
        navigator.replans.append(Replan(navigator.time, tuple(map(float, navigator.position)),
                                        f"station {index + 1} moved to another viewpoint: {why}"))
        self.walked[index] = navigator.go(others[pick][:2, 3])
        return others[pick]

    def _wait_for_zones(self, index: int, T_world_camera: np.ndarray, why: str) -> np.ndarray | None:
        """Wait (up to ``MAX_WAIT_S``) for a zone change that lets the robot reach the station: a worker pausing."""
        navigator = self.navigator
        start = navigator.time
        for change in navigator.changes_within(MAX_WAIT_S):
            navigator.wait(change - navigator.time)
            try:
                self.walked[index] = navigator.go(T_world_camera[:2, 3])
            except PlanningError:
                continue
            navigator.replans.append(Replan(change, tuple(map(float, self.walked[index][0])),
                                            f"station {index + 1}: waited {change - start:.0f} s for a zone to "
                                            f"clear ({why})"))
            return T_world_camera
        return None

    def _explained(self) -> np.ndarray:
        """Cells the map already accounts for: occupied, grown by ``EXPLAINED_MARGIN``."""
        grid = self.navigator.grid
        return ndimage.distance_transform_edt(~grid.occupied) * grid.resolution <= EXPLAINED_MARGIN

    def _unexplained(self, detection: Detection, explained: np.ndarray) -> bool:
        """Do most of the detection's points in the robot's band lie where the map has nothing?"""
        grid = self.navigator.grid
        low, high = grid.z_band
        points = detection.points_world[(detection.points_world[:, 2] >= low) & (detection.points_world[:, 2] <= high)]
        if len(points) == 0:
            return False
        cells = np.floor(grid.frame.to_cells(points[:, :2])).astype(int)
        inside = (cells[:, 0] >= 0) & (cells[:, 1] >= 0) & (cells[:, 0] < grid.frame.shape[1]) & (
            cells[:, 1] < grid.frame.shape[0])
        hits = np.zeros(len(points), bool)
        hits[inside] = explained[cells[inside, 1], cells[inside, 0]]
        return float(np.mean(hits)) < 0.5
