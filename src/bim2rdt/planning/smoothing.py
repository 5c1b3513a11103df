"""Smoothing a grid path into a few straight legs that stay in free space.

pyastar2d's 8-connected moves all cost the same, so its paths are staircases. Two steps make them a robot's
path: keep only the cells where the direction changes (the straight runs between are free by construction),
then pull the string: from each kept point, jump to a far later point in line of sight, found by galloping
then bisection (a jump is only ever taken after a line-of-sight check, so any point the search lands on is
safe, even where visibility along the path is not monotone). The search can stop short where visibility is not
monotone, so the pull is repeated on its own result until it keeps every point (two or three rounds, on a
handful of points).

Points are continuous cell coordinates (row, col), cell (i, j) spanning [i, i+1) x [j, j+1), so the exact start
and goal take part, not only their cells' centres. Line of sight is exact: the segment's every crossing of a
grid line is found, and each cell it passes through (its supercover, less cells it only touches at a corner)
must be free.
"""

from __future__ import annotations

import math

import numpy as np

MAX_ROUNDS = 3
_TOUCH = 1e-9


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
    cell. (Plain floats and truncation instead of floor: coordinates are >= 0; this runs a few hundred times per
    path.)"""
    a0, a1 = float(a[0]), float(a[1])
    d0, d1 = float(b[0]) - a0, float(b[1]) - a1
    crossings = [np.array([0.0, 1.0])]
    for start, delta in ((a0, d0), (a1, d1)):
        if delta:
            low, high = (start, start + delta) if delta > 0 else (start + delta, start)
            crossings.append((np.arange(math.floor(low) + 1.0, math.ceil(high)) - start) / delta)
    t = np.concatenate(crossings)
    t.sort()
    middles = ((t[:-1] + t[1:]) * 0.5)[np.diff(t) > _TOUCH]
    return not blocked[(a0 + middles * d0).astype(np.intp), (a1 + middles * d1).astype(np.intp)].any()


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
