"""Smoothing a grid path into a few straight legs that stay in free space.

pyastar2d's 8-connected moves all cost the same, so its paths are staircases. Two steps make them a robot's
path: keep only the cells where the direction changes (the straight runs between are free by construction),
then pull the string: from each kept point, jump to a far later point in line of sight, found by galloping
then bisection (a jump is only ever taken after a line-of-sight check, so any point the search lands on is
safe, even where visibility along the path is not monotone). The search can stop short where visibility is not
monotone, so the pull is repeated on its own result until it keeps every point (two or three rounds, on a
handful of points). Line of sight samples the segment every half cell.
"""

from __future__ import annotations

import numpy as np


MAX_ROUNDS = 4


def smooth(cells: np.ndarray, blocked: np.ndarray) -> np.ndarray:
    """The corners (K, 2) of a smoothed version of an 8-connected grid path ``cells`` (N, 2), ends kept."""
    corners = pull_string(turning_points(cells), blocked)
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
    """True when the segment between cell centres ``a`` and ``b`` (row, col) crosses no blocked cell."""
    step = b - a
    count = int(2 * max(abs(step[0]), abs(step[1]))) + 2
    t = np.arange(count) * (1.0 / (count - 1))
    rows = (a[0] + 0.5 + t * step[0]).astype(np.intp)  # + 0.5 then truncation: nearest cell (indices are >= 0)
    cols = (a[1] + 0.5 + t * step[1]).astype(np.intp)
    return not blocked[rows, cols].any()


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
    (the cost of a check is its length) where most jumps are a few corners long."""
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
