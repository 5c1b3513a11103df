"""Smoothing a grid path into a few straight legs that stay in free space.

pyastar2d's 8-connected moves all cost the same, so its paths are staircases. Two steps make them a robot's
path: keep only the cells where the direction changes (the straight runs between are free by construction),
then pull the string: from each kept point, jump to a far later point in line of sight, found by galloping
then bisection (a jump is only ever taken after a line-of-sight check, so any point the search lands on is
safe, even where visibility along the path is not monotone). The search can stop short where visibility is not
monotone, so the pull is repeated on its own result until it keeps every point (two or three rounds, on a
handful of points).

Points are continuous cell coordinates (row, col), cell (i, j) spanning [i, i+1) x [j, j+1), so the exact start
and goal take part, not only their cells' centres. Line of sight is exact: each cell the segment passes through
(its supercover, less cells it only touches at a corner or an edge) must be free.
"""

from __future__ import annotations

import math

import numpy as np

MAX_ROUNDS = 3


def smooth(cells: np.ndarray, blocked: np.ndarray, start_rc: np.ndarray, goal_rc: np.ndarray) -> np.ndarray:
    """Corners (K, 2) in continuous (row, col) of a smoothed version of the 8-connected grid path ``cells``
    (N, 2) from the exact point ``start_rc`` to ``goal_rc`` (which lie in its first and last cells)."""
    corners = np.vstack([start_rc, turning_points(cells) + 0.5, goal_rc])
    for _ in range(MAX_ROUNDS):
        pulled = pull_string(corners, blocked)
        if len(pulled) == len(corners):
            break
        corners = pulled
    return corners


def turning_points(cells: np.ndarray) -> np.ndarray:
    """The cells (N, 2) of a path where its step direction changes, with both ends: (K, 2)."""
    if len(cells) <= 2:
        return cells
    steps = np.diff(cells, axis=0)
    turns = np.flatnonzero(np.any(steps[1:] != steps[:-1], axis=1)) + 1
    return cells[np.concatenate([[0], turns, [len(cells) - 1]])]


def in_sight(blocked: np.ndarray, a: np.ndarray, b: np.ndarray) -> bool:
    """True when the segment from ``a`` to ``b`` (continuous row, col, inside the grid) passes through no blocked
    cell. Walking the axis the segment changes most along, it spans one or two cells of the other axis per step:
    the first and last of those are checked. (Plain floats and truncation instead of floor, coordinates being
    >= 0: this runs a few hundred times per path.)"""
    a0, a1, b0, b1 = float(a[0]), float(a[1]), float(b[0]), float(b[1])
    if abs(b1 - a1) < abs(b0 - a0):
        blocked, (a0, a1, b0, b1) = blocked.T, (a1, a0, b1, b0)
    if b1 < a1:
        a0, a1, b0, b1 = b0, b1, a0, a1
    if b1 == a1:
        return not blocked[int(a0), int(a1)]
    first_col, last_col = int(a1), max(math.ceil(b1) - 1, int(a1))
    edges = np.clip(np.arange(first_col, last_col + 2, dtype=float), a1, b1)
    crossing = a0 + (edges - a1) * ((b0 - a0) / (b1 - a1))
    low, high = np.minimum(crossing[:-1], crossing[1:]), np.maximum(crossing[:-1], crossing[1:])
    cols = np.arange(first_col, last_col + 1)
    rows_low = low.astype(np.intp)
    rows_high = np.maximum(np.ceil(high).astype(np.intp) - 1, rows_low)
    return not (blocked[rows_low, cols].any() or blocked[rows_high, cols].any())


def pull_string(points: np.ndarray, blocked: np.ndarray) -> np.ndarray:
    """The subset of ``points`` (K, 2) joined by straight free segments, from the first to the last."""
    kept, here, last = [0], 0, len(points) - 1
    while here < last:
        here = _farthest_in_sight(points, blocked, here, last)
        kept.append(here)
    return points[kept]


def _farthest_in_sight(points: np.ndarray, blocked: np.ndarray, here: int, last: int) -> int:
    """A far point after ``here`` in its line of sight: gallop (1, 2, 4, ... ahead) until sight fails, then
    bisect between the last point seen and the first not seen. Galloping keeps the checked segments short
    (the cost of a check is its length) where most jumps are a few corners long. The next point is taken
    even unseen: consecutive points are joined by the grid path itself."""
    seen, step = here + 1, 1
    while True:
        ahead = min(here + 2 * step, last)
        if ahead == seen or not in_sight(blocked, points[here], points[ahead]):
            break
        seen, step = ahead, 2 * step
        if seen == last:
            return last
    unseen = ahead
    while unseen - seen > 1:
        middle = (seen + unseen) // 2
        if in_sight(blocked, points[here], points[middle]):
            seen = middle
        else:
            unseen = middle
    return seen
