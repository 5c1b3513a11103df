"""The plan search's scan over shifts and turns (:func:`bim2rdt.verify.planned.search_shift`), found without
scoring every candidate: the answer of the full scan, bit for bit.

The full scan poses the object's sensor-facing samples at every turn and every shift of a grid and counts, for
each pose, the samples with a located point within ``support`` (a k-d tree query per sample: 441 shifts x ~350
samples on the coarse grid, 5 turns x 81 shifts on the fine one; 40 % of verify's objects stage on office1).

Here each candidate first gets a cheap upper bound: the samples whose grid cell lies within reach of a cell
holding a located point (an occupancy grid of cells a whole fraction of the shift step, grown by the cells
``support`` spans, looked up by integer cell offsets: no distances). Candidates are then scored exactly (the
same k-d tree query, on pykdtree, the same answers as scipy's ``cKDTree``: ``SampleTree``), best bound first,
until no bound left can beat, or tie ahead of, the best exact count: the coarse grid scores ~5 % of its shifts.
Only the samples within reach are queried (a sample out of reach has no point within ``support``).
"""

from __future__ import annotations

import numpy as np

from bim2rdt.registration import SampleTree

BATCH = 8
"""Candidates scored per k-d tree query (one query for several poses; the stop is tested between batches)."""
GRID_CELLS_MAX = 8_000_000
"""An occupancy grid larger than this (cells) is not built: every candidate is then scored (a huge object)."""


class Located:
    """The located points an object's coverage is counted on, with a k-d tree over them.

    Args:
        points: (N, 3) located points, metres.
    """

    def __init__(self, points: np.ndarray) -> None:
        self.points = np.asarray(points, dtype=float)
        self.tree = SampleTree(self.points)

    def query(self, points: np.ndarray, distance_upper_bound: float = np.inf):
        """The nearest located point of each of ``points`` (M, 3), as ``cKDTree.query``.

        Args:
            points: (M, 3) query points, metres.
            distance_upper_bound: Farther neighbours are misses (distance inf, index N), metres.

        Returns:
            (distances (M,), indices (M,)).
        """
        return self.tree.query(points, distance_upper_bound=distance_upper_bound)


def best_shift(local: np.ndarray, start: np.ndarray, yaws_deg, steps: np.ndarray, located: Located,
               support: float) -> tuple[np.ndarray, float]:
    """The pose among ``start`` turned by ``yaws_deg`` about its origin's vertical and shifted by ``steps`` in x
    and y whose posed samples ``local`` (body frame) find the most located points within ``support`` m; of equal
    counts the first in turn-then-shift order (turns as given, shifts x-major).

    Args:
        local: (n, 3) sensor-facing body samples, body frame, metres.
        start: 4x4 pose to turn and shift.
        yaws_deg: Turns about the pose's own vertical, degrees.
        steps: Shifts along each of x and y, metres (evenly spaced).
        located: The located points.
        support: A sample with a located point nearer than this is covered, metres.

    Returns:
        (the best pose, its count as a share of ``local``).
    """
    shifts = np.array([(x, y) for x in steps for y in steps])
    offsets = np.c_[shifts, np.zeros(len(shifts))]
    poses = [start @ _turn(yaw) for yaw in yaws_deg]
    placed = np.stack([local @ pose[:3, :3].T + pose[:3, 3] for pose in poses])  # (Y, n, 3)
    reach = _within_reach(located.points, placed, shifts, steps, support)  # (Y*S, n) bool, or None
    counts = _counts(placed, offsets, reach, located, support)
    best = int(np.argmax(counts))  # the first of the highest, as the full scan keeps it
    turn, k = divmod(best, len(shifts))
    pose = poses[turn].copy()
    pose[:2, 3] += shifts[k]
    return pose, int(counts[best]) / max(len(local), 1)


def _turn(yaw_deg: float) -> np.ndarray:
    c, s = np.cos(np.deg2rad(yaw_deg)), np.sin(np.deg2rad(yaw_deg))
    turn = np.eye(4)
    turn[:2, :2] = [[c, -s], [s, c]]
    return turn


def _counts(placed: np.ndarray, offsets: np.ndarray, reach: np.ndarray | None, located: Located,
            support: float) -> np.ndarray:
    """(Y*S,) covered samples of every candidate that could be the scan's answer, -1 for the others (their bound
    is below the best count, or equal to it behind it in scan order)."""
    turns, n = placed.shape[0], placed.shape[1]
    total = turns * len(offsets)
    counts = np.full(total, -1, dtype=np.int64)
    bound = np.full(total, n) if reach is None else reach.sum(axis=1)
    order = np.lexsort((np.arange(total), -bound))  # best bound first, scan order among equals
    best, best_at = -1, total
    for start in range(0, total, BATCH):
        first = order[start]
        if bound[first] < best or (bound[first] == best and first > best_at):
            break
        chunk = order[start:start + BATCH]
        moved = placed[chunk // len(offsets)] + offsets[chunk % len(offsets)][:, None, :]  # (B, n, 3)
        asked = np.ones(moved.shape[:2], dtype=bool) if reach is None else reach[chunk]
        gap, _ = located.query(moved[asked], distance_upper_bound=support)
        hit = np.zeros(asked.shape, dtype=bool)
        hit[asked] = np.isfinite(gap)
        counts[chunk] = hit.sum(axis=1)
        for g in chunk:
            if counts[g] > best or (counts[g] == best and g < best_at):
                best, best_at = int(counts[g]), int(g)
    return counts


def _within_reach(points: np.ndarray, placed: np.ndarray, shifts: np.ndarray, steps: np.ndarray,
                  support: float) -> np.ndarray | None:
    """(Y*S, n) bool: which posed samples lie in a grid cell within reach of a located point's cell, a superset of
    those with a point nearer than ``support`` (None: no grid, every sample counts as within reach).

    The cells are ``step / m`` wide (m whole), so a shift moves a sample by whole cells: a sample's cell plus the
    shift's cells. A point nearer than ``support`` lies at most ``floor(support / cell) + 1`` cells away on each
    axis (the +1 also absorbs the rounding of the shifted coordinates)."""
    if len(points) == 0 or len(steps) < 2:
        return None
    step = float(steps[1] - steps[0])
    if step <= 0 or not np.allclose(np.diff(steps), step, rtol=0.0, atol=1e-9 * step):
        return None  # uneven steps do not move a sample by whole cells
    cell = step / max(1, round(2 * step / support))  # about half the support: a bound ~1.6 x its reach
    grow = int(np.floor(support / cell + 1e-6)) + 1
    base = np.floor((placed - placed.min(axis=(0, 1))) / cell).astype(np.int64)  # (Y, n, 3)
    moves = np.round((shifts - shifts.min(axis=0)) / cell).astype(np.int64)  # (S, 2) whole cells
    lo = placed.min(axis=(0, 1)) + np.r_[shifts.min(axis=0), 0.0]
    span = base.max(axis=(0, 1)) + np.r_[moves.max(axis=0), 0] + 1
    occupied = np.floor((points - lo) / cell).astype(np.int64)
    occupied = occupied[np.all((occupied >= -grow) & (occupied < span + grow), axis=1)]
    if len(occupied) == 0:
        return np.zeros((placed.shape[0] * len(shifts), placed.shape[1]), dtype=bool)
    shape = span + 2 * grow
    if int(np.prod(shape)) > GRID_CELLS_MAX:
        return None
    grid = np.zeros(tuple(shape), dtype=bool)
    grid[tuple((np.unique(occupied, axis=0) + grow).T)] = True
    grid = _grow(grid, grow)
    sample = np.ravel_multi_index(tuple((base + grow).reshape(-1, 3).T), grid.shape).reshape(base.shape[:2])
    move = np.ravel_multi_index((moves[:, 0], moves[:, 1], np.zeros(len(moves), dtype=np.int64)), grid.shape)
    return grid.ravel()[sample[:, None, :] + move[None, :, None]].reshape(-1, placed.shape[1])


def _grow(grid: np.ndarray, cells: int) -> np.ndarray:
    """``grid`` dilated by a cube of ``cells`` on each side (three passes of shifted ORs, one per axis)."""
    for axis in range(3):
        out = grid.copy()
        length = grid.shape[axis]
        for k in range(1, min(cells, length - 1) + 1):
            lead = [slice(None)] * 3
            tail = [slice(None)] * 3
            lead[axis], tail[axis] = slice(k, None), slice(None, length - k)
            out[tuple(lead)] |= grid[tuple(tail)]
            out[tuple(tail)] |= grid[tuple(lead)]
        grid = out
    return grid
