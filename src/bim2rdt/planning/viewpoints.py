"""Where the robot can stand to look at something: free ground, reachable from where it starts, with a line of
sight over the structure to the target.

The caller (the mission) proposes viewpoints in its own order of preference (a view across an object's long
side, facing the site's interior); the first one that passes all three checks wins. Reachability is the free
region of the start (8-connected, as the planner moves), computed once per grid and start.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
from scipy import ndimage

from bim2rdt.planning.grid import OccupancyGrid
from bim2rdt.planning.sight import line_of_sight, occluders

_EIGHT = np.ones((3, 3), bool)


def reachable(grid: OccupancyGrid, start_xy: np.ndarray | tuple[float, float]) -> np.ndarray:
    """The free cells the robot can reach from a start.

    Args:
        grid: The occupancy grid.
        start_xy: World (x, y) of the robot, metres.

    Returns:
        (rows, cols) bool; all False if the start is blocked or outside the grid.
    """
    cell = grid.frame.cell_of(start_xy)
    if not grid.frame.contains(cell) or grid.blocked[cell]:
        return np.zeros(grid.frame.shape, bool)
    labels, _ = ndimage.label(~grid.blocked, structure=_EIGHT)
    return labels == labels[cell]


def pick_viewpoint(grid: OccupancyGrid, target_xy: np.ndarray | tuple[float, float], candidates_xy: Sequence,
                   region: np.ndarray, ignore: Iterable[str] = ()) -> int | None:
    """The first candidate viewpoint the robot can reach that sees the target.

    Args:
        grid: The occupancy grid.
        target_xy: World (x, y) of the target, metres.
        candidates_xy: World (x, y) candidates, metres, in order of preference.
        region: (rows, cols) bool, the reachable cells (see ``reachable``).
        ignore: The target's own GlobalIds (a column looked at does not hide itself).

    Returns:
        The index of the first candidate inside ``region`` with a line of sight to the target, or None.
    """
    blocking = occluders(grid, ignore)
    for index, xy in enumerate(candidates_xy):
        cell = grid.frame.cell_of(xy)
        if grid.frame.contains(cell) and region[cell] and line_of_sight(grid, xy, target_xy, blocking=blocking):
            return index
    return None
