"""``plan_path``: the robot's path between two points of a grid, in world metres.

A* runs on pyastar2d's C++ search (8-connected, every move costing the entered cell's weight), then the staircase it returns is
smoothed into straight legs through free space (``smoothing``), checked from the exact points asked for, not
their cells' centres. A start or goal the robot cannot stand on, and a goal it cannot reach, are
``PlanningError``s that say what is in the way.
"""

from __future__ import annotations

import numpy as np
import pyastar2d

from bim2rdt.planning.blockage import describe_blocked_point, describe_no_path
from bim2rdt.planning.errors import PlanningError
from bim2rdt.planning.grid import OccupancyGrid
from bim2rdt.planning.smoothing import smooth


def plan_path(grid: OccupancyGrid, start_xy: np.ndarray | tuple[float, float],
              goal_xy: np.ndarray | tuple[float, float]) -> np.ndarray:
    """Plan a path for the robot's centre: A* on the grid (8-connected), then smoothed to straight legs.

    Args:
        grid: The occupancy grid, obstacles grown by the robot's radius.
        start_xy: World (x, y) of the start, metres.
        goal_xy: World (x, y) of the goal, metres.

    Returns:
        (N,2) waypoints in world metres (N >= 2), from start to goal exactly, every leg in free space.

    Raises:
        PlanningError: A start or goal that is not a finite point or is blocked, or no path between them; the
            message names what blocks.
    """
    start_xy, goal_xy = _point(start_xy, "start"), _point(goal_xy, "goal")
    start_cell, goal_cell = _free_cell(grid, start_xy, "start"), _free_cell(grid, goal_xy, "goal")
    cells = _astar(grid, start_cell, goal_cell)
    if cells is None:
        raise PlanningError(describe_no_path(grid, start_cell, goal_cell, start_xy, goal_xy))
    start_rc, goal_rc = grid.frame.to_cells(start_xy)[::-1], grid.frame.to_cells(goal_xy)[::-1]
    corners = smooth(cells, grid.blocked, start_rc, goal_rc)
    waypoints = grid.frame.to_world(corners[:, ::-1])
    waypoints[0], waypoints[-1] = start_xy, goal_xy  # exact, not as rounded through cell coordinates
    return waypoints


def path_length(path: np.ndarray) -> float:
    """The length of a path.

    Args:
        path: (N,2) waypoints, metres.

    Returns:
        The sum of its legs, metres.
    """
    return float(np.sum(np.linalg.norm(np.diff(np.asarray(path, float), axis=0), axis=1)))


def _astar(grid: OccupancyGrid, start: tuple[int, int], goal: tuple[int, int]) -> np.ndarray | None:
    """pyastar2d's C search on the grid's cost (8-connected). ``grid.cost`` is float32, C-contiguous and >= 1 by
    construction, so the checks and the copy ``pyastar2d.astar_path`` repeats on every call (a min() scan and a
    flatten() of the whole grid) are skipped; the result is the same path."""
    rows, cols = grid.frame.shape
    return pyastar2d.astar.astar(grid.cost.reshape(-1), rows, cols, start[0] * cols + start[1],
                                 goal[0] * cols + goal[1], True, int(pyastar2d.Heuristic.DEFAULT))


def _point(xy, role: str) -> np.ndarray:
    try:
        point = np.asarray(xy, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise PlanningError(f"{role} must be (x, y) in metres (got {xy!r})") from None
    if point.shape != (2,) or not np.all(np.isfinite(point)):
        raise PlanningError(f"{role} must be a finite (x, y) in metres (got {xy!r})")
    return point


def _free_cell(grid: OccupancyGrid, xy: np.ndarray, role: str) -> tuple[int, int]:
    cell = grid.frame.cell_of(xy)
    if not grid.frame.contains(cell) or grid.blocked[cell]:
        raise PlanningError(describe_blocked_point(grid, xy, role))
    return cell
