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


def reachable(grid: OccupancyGrid, start_xy) -> np.ndarray:
    """Bool (rows, cols): the free cells the robot can reach from ``start_xy`` (all False if it stands blocked)."""
    cell = grid.frame.cell_of(start_xy)
    if not grid.frame.contains(cell) or grid.blocked[cell]:
        return np.zeros(grid.frame.shape, bool)
    labels, _ = ndimage.label(~grid.blocked, structure=_EIGHT)
    return labels == labels[cell]


def pick_viewpoint(grid: OccupancyGrid, target_xy, candidates_xy: Sequence, region: np.ndarray,
                   ignore: Iterable[str] = ()) -> int | None:
    """Index of the first candidate (x, y) inside the reachable ``region`` (see ``reachable``) with a line of
    sight to ``target_xy``; None if there is none. ``ignore``: the target's own GlobalIds (a column looked at
    does not hide itself)."""
    blocking = occluders(grid, ignore)
    for index, xy in enumerate(candidates_xy):
        cell = grid.frame.cell_of(xy)
        if grid.frame.contains(cell) and region[cell] and line_of_sight(grid, xy, target_xy, blocking=blocking):
            return index
    return None
