"""Growing obstacles by the robot's radius, for the whole grid or only where something changed.

A cell is blocked when its centre is closer than ``robot_radius + resolution / 2`` to the centre of an occupied
cell: the half cell keeps the margin whole although the obstacle's edge can lie anywhere inside its cell.
Blocking a cell depends only on occupied cells within that distance, so after a change inside a window only
the window grown by the radius needs recomputing, from the occupied cells in the window grown twice; that is
what makes replanning after one new obstacle cheap.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage


def reach_cells(robot_radius: float, resolution: float) -> float:
    """The blocking distance in cells."""
    return robot_radius / resolution + 0.5


def inflate(occupied: np.ndarray, reach: float) -> np.ndarray:
    """Cells within ``reach`` cells (centre to centre) of an occupied cell."""
    if not occupied.any():
        return np.zeros_like(occupied)
    if reach <= 0.5:
        return occupied.copy()
    return ndimage.distance_transform_edt(~occupied) < reach


def reinflate(blocked: np.ndarray, occupied: np.ndarray, window: tuple[slice, slice], reach: float) -> None:
    """Recompute ``blocked`` in place around ``window`` (a changed region of ``occupied``)."""
    margin = int(np.ceil(reach))
    inner = _grown(window, margin, occupied.shape)
    outer = _grown(window, 2 * margin, occupied.shape)
    local = inflate(occupied[outer], reach)
    offset = inner[0].start - outer[0].start, inner[1].start - outer[1].start
    blocked[inner] = local[offset[0]:offset[0] + inner[0].stop - inner[0].start,
                           offset[1]:offset[1] + inner[1].stop - inner[1].start]


def _grown(window: tuple[slice, slice], margin: int, shape: tuple[int, int]) -> tuple[slice, slice]:
    rows, cols = window
    return (slice(max(rows.start - margin, 0), min(rows.stop + margin, shape[0])),
            slice(max(cols.start - margin, 0), min(cols.stop + margin, shape[1])))
