"""What the robot can see from where it stands, and whether a planned path is still free.

Line of sight runs in plan over the occluders: the BIM's structure in the robot's height band (walls, columns,
closed doors, stairs, furniture), not the site objects (``IfcBuildingElementProxy``: the things the robot is
there to look at) and not keep-out zones (they are rules, not walls). A sight line ends short of its target by
``TARGET_MARGIN`` so an object standing against a wall is still seen from the room.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np

from bim2rdt.planning.smoothing import in_sight

if TYPE_CHECKING:
    from bim2rdt.planning.grid import OccupancyGrid

SITE_OBJECT_CLASSES = ("IfcBuildingElementProxy",)
TARGET_MARGIN = 0.3
"""Metres short of the target where a sight line stops checking (its own body, a wall it leans on)."""


def occluders(grid: OccupancyGrid, ignore: Iterable[str] = ()) -> np.ndarray:
    """The cells of the BIM structure that block a camera's view (walls, columns, doors; not site objects).

    Args:
        grid: The occupancy grid.
        ignore: GlobalIds of elements that do not count (the target itself).

    Returns:
        (rows, cols) bool.
    """
    ignored = set(ignore)
    return grid.layer_of([fp for fp in grid.footprints if fp.kind in ("element", "door")
                          and fp.ifc_class not in SITE_OBJECT_CLASSES and fp.global_id not in ignored])


def line_of_sight(grid: OccupancyGrid, eye_xy: np.ndarray | tuple[float, float],
                  target_xy: np.ndarray | tuple[float, float], ignore: Iterable[str] = (),
                  blocking: np.ndarray | None = None) -> bool:
    """Whether a camera at one point sees another across the floor plan. The last ``TARGET_MARGIN`` metres
    before the target are not checked (its own body, a wall it leans on).

    Args:
        grid: The occupancy grid.
        eye_xy: World (x, y) of the camera, metres.
        target_xy: World (x, y) of the target, metres.
        ignore: GlobalIds of elements that do not count as occluders.
        blocking: A precomputed ``occluders(grid, ignore)``, for many checks; None computes it.

    Returns:
        True when no occluder stands between them and both lie inside the grid.
    """
    eye, target = np.asarray(eye_xy, float), np.asarray(target_xy, float)
    distance = float(np.linalg.norm(target - eye))
    if distance <= TARGET_MARGIN:
        return True
    end = target - (target - eye) * (TARGET_MARGIN / distance)
    mask = occluders(grid, ignore) if blocking is None else blocking
    a, b = grid.frame.to_cells(eye)[::-1], grid.frame.to_cells(end)[::-1]
    if not (grid.frame.contains(grid.frame.cell_of(eye)) and grid.frame.contains(grid.frame.cell_of(end))):
        return False
    return in_sight(mask, a, b)


def first_blocked_leg(grid: OccupancyGrid, path: np.ndarray) -> int | None:
    """The first leg of a path that crosses a blocked cell: after the grid changed (a new object, a worker's
    zone), is the path the robot is on still good?

    Args:
        grid: The occupancy grid now.
        path: (N,2) world waypoints, metres.

    Returns:
        The index of the first blocked leg (or one leaving the grid), or None when the path is clear.
    """
    cells = grid.frame.to_cells(np.asarray(path, float))[:, ::-1]
    rows, cols = grid.frame.shape
    for leg, (a, b) in enumerate(zip(cells[:-1], cells[1:])):
        inside = all(0 <= p[0] < rows and 0 <= p[1] < cols for p in (a, b))
        if not inside or not in_sight(grid.blocked, a, b):
            return leg
    return None
