"""Saying what blocks: why the robot cannot stand somewhere, and what cuts a goal off from the start.

When no path exists, start and goal lie in different free regions. The footprints whose grown cells touch both
regions are what stands between them. A removable one (an observed object, a keep-out zone, a worker, a closed
door) that alone would open the way is named as *the* blocker; otherwise the message lists what closes the
smaller region in (the walls of a closed room, a door, the floor's edge).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy import ndimage

from bim2rdt.planning.inflation import inflate

if TYPE_CHECKING:
    from bim2rdt.planning.grid import OccupancyGrid
    from bim2rdt.planning.raster import Footprint

REMOVABLE_KINDS = ("object", "zone", "person", "door")
MAX_NAMED = 4
_EIGHT = np.ones((3, 3), bool)


def describe_blocked_point(grid: OccupancyGrid, xy, role: str) -> str:
    """'start (1.00, 2.00) is inside Wall W1 (IfcWall)' or '... is within 0.35 m (the robot's radius) of ...'."""
    where = f"{role} ({_metres(xy[0])}, {_metres(xy[1])})"
    if not grid.frame.contains(grid.frame.cell_of(xy)):
        x0, x1, y0, y1 = grid.frame.extent
        return f"{where} is outside the grid of storey {grid.storey!r} (x {x0:.2f}..{x1:.2f}, y {y0:.2f}..{y1:.2f})"
    blockers = grid.blockers_at(xy)
    if not blockers:
        return f"{where} is blocked"
    inside = [fp.label for fp, gap in blockers if gap == 0.0]
    if inside:
        return f"{where} is inside {_names(inside)}"
    return (f"{where} is within {grid.robot_radius:.2f} m (the robot's radius) of "
            f"{_names([fp.label for fp, _ in blockers])}")


def _metres(value: float) -> str:
    """A coordinate for a message: centimetres on a site's scale, 3 digits far beyond it (1e+308)."""
    return f"{value:.2f}" if abs(value) < 1e6 else f"{value:.3g}"


def describe_no_path(grid: OccupancyGrid, start_cell: tuple[int, int], goal_cell: tuple[int, int], start_xy,
                     goal_xy) -> str:
    """Why no free path joins two free cells: the one removable thing that opens it, or what closes one in."""
    head = f"no path from ({start_xy[0]:.2f}, {start_xy[1]:.2f}) to ({goal_xy[0]:.2f}, {goal_xy[1]:.2f})"
    labels, _ = ndimage.label(~grid.blocked, structure=_EIGHT)
    start_region, goal_region = labels == labels[start_cell], labels == labels[goal_cell]
    start_rim, goal_rim = _rim(start_region, grid.blocked), _rim(goal_region, grid.blocked)
    between = [fp for fp in grid.footprints if _touches(fp, grid, start_rim) and _touches(fp, grid, goal_rim)]
    for fp in [fp for fp in between if fp.kind in REMOVABLE_KINDS]:
        if _opens(grid, fp, start_cell, goal_cell):
            return f"{head}: blocked by {fp.label}; without it the way is free"
    if between:
        return f"{head}: the way is closed by {_names([fp.label for fp in between])}"
    smaller, rim = ("start", start_rim) if start_region.sum() <= goal_region.sum() else ("goal", goal_rim)
    area = min(start_region.sum(), goal_region.sum()) * grid.resolution ** 2
    around = sorted(grid.footprints, key=lambda fp: -_contact(fp, grid, rim))
    around = [fp.label for fp in around if _contact(fp, grid, rim) > 0]
    return f"{head}: the {smaller}'s free area ({area:.1f} m^2) is closed in by {_names(around)}"


def _names(labels: list[str]) -> str:
    unique = list(dict.fromkeys(labels))
    more = len(unique) - MAX_NAMED
    return ", ".join(unique[:MAX_NAMED]) + (f" and {more} more" if more > 0 else "")


def _rim(region: np.ndarray, blocked: np.ndarray) -> np.ndarray:
    """Blocked cells next to a free region."""
    return ndimage.binary_dilation(region, structure=_EIGHT) & blocked


def _grown(fp: Footprint, grid: OccupancyGrid) -> tuple[tuple[slice, slice], np.ndarray]:
    """The cells a footprint blocks: its window grown by the reach, and the mask there."""
    margin = int(np.ceil(grid.reach))
    rows, cols = grid.frame.shape
    r0, c0 = max(fp.row0 - margin, 0), max(fp.col0 - margin, 0)
    r1, c1 = min(fp.row0 + fp.mask.shape[0] + margin, rows), min(fp.col0 + fp.mask.shape[1] + margin, cols)
    local = np.zeros((r1 - r0, c1 - c0), bool)
    local[fp.row0 - r0:fp.row0 - r0 + fp.mask.shape[0], fp.col0 - c0:fp.col0 - c0 + fp.mask.shape[1]] = fp.mask
    return (slice(r0, r1), slice(c0, c1)), inflate(local, grid.reach)


def _contact(fp: Footprint, grid: OccupancyGrid, rim: np.ndarray) -> int:
    window, grown = _grown(fp, grid)
    return int(np.count_nonzero(grown & rim[window]))


def _touches(fp: Footprint, grid: OccupancyGrid, rim: np.ndarray) -> bool:
    return _contact(fp, grid, rim) > 0


def _opens(grid: OccupancyGrid, fp: Footprint, start_cell, goal_cell) -> bool:
    """Would the way be free without this one footprint?"""
    if fp in grid.objects or fp in grid.zones:
        lighter = grid._changed(objects=tuple(o for o in grid.objects if o is not fp),
                                zones=tuple(z for z in grid.zones if z is not fp))
    else:
        lighter = grid._changed(base=tuple(b for b in grid.base if b is not fp))
    labels, _ = ndimage.label(~lighter.blocked, structure=_EIGHT)
    return labels[start_cell] == labels[goal_cell]
