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
    """Bool (rows, cols): cells of the BIM structure that block a camera's view (less elements ``ignore``d)."""
    ignored = set(ignore)
    return grid.layer_of([fp for fp in grid.footprints if fp.kind in ("element", "door")
                          and fp.ifc_class not in SITE_OBJECT_CLASSES and fp.global_id not in ignored])


def line_of_sight(grid: OccupancyGrid, eye_xy, target_xy, ignore: Iterable[str] = (),
                  blocking: np.ndarray | None = None) -> bool:
    """True when no occluder stands between ``eye_xy`` and ``target_xy`` (world metres). ``blocking`` is a
    precomputed ``occluders(grid, ignore)`` for many checks."""
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
    """Index of the first leg of ``path`` (N, 2) that crosses a blocked cell of ``grid``, or None: after the
    grid changed (a new object, a worker's zone), is the path the robot is on still good?"""
    cells = grid.frame.to_cells(np.asarray(path, float))[:, ::-1]
    rows, cols = grid.frame.shape
    for leg, (a, b) in enumerate(zip(cells[:-1], cells[1:])):
        inside = all(0 <= p[0] < rows and 0 <= p[1] < cols for p in (a, b))
        if not inside or not in_sight(grid.blocked, a, b):
            return leg
    return None
