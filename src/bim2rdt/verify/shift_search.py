"""The plan search's scan over shifts and turns (:func:`bim2rdt.verify.planned.search_shift`): every candidate
counted exactly, in compiled code, the answer the full scan of k-d tree queries gives, bit for bit.

The full scan poses the object's sensor-facing samples at every turn and every shift of a grid and counts, for
each pose, the samples with a located point within ``support`` (441 shifts x ~350 samples on the coarse grid, 5
turns x 81 shifts on the fine one). A k-d tree query per posed sample, even pruned by an occupancy bound (decision
0039), cost ~0.15 s of an office1 frame; :func:`bim2rdt.verify.kernels.shift_counts` counts every candidate in
~0.003 s a scan (decision 0046), with pykdtree's own distance test. numba is imported by the first scan (verify's
setup: :func:`load_kernels`), not by importing this module.
"""

from __future__ import annotations

import functools

import numpy as np

from bim2rdt.registration import SampleTree


class Located:
    """The located points an object's coverage is counted on, with a k-d tree over them and a copy sorted by
    height (the plan search's), each made when first asked for.

    Args:
        points: (N, 3) located points, metres.
    """

    def __init__(self, points: np.ndarray) -> None:
        self.points = np.asarray(points, dtype=float)

    @functools.cached_property
    def tree(self) -> SampleTree:
        """A k-d tree over the points."""
        return SampleTree(self.points)

    @functools.cached_property
    def by_height(self) -> np.ndarray:
        """(N, 3) the points sorted by z (a stable sort), C-contiguous float64."""
        return np.ascontiguousarray(self.points[np.argsort(self.points[:, 2], kind="stable")], dtype=np.float64)

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
        steps: Shifts along each of x and y, metres (ascending: the kernel finds each point's shifts by bisection;
            else every shift is tested).
        located: The located points.
        support: A sample with a located point nearer than this is covered, metres.

    Returns:
        (the best pose, its count as a share of ``local``).
    """
    from bim2rdt.verify.kernels import shift_counts  # numba's import waits for the first scan

    shifts = np.array([(x, y) for x in steps for y in steps])
    poses = [start @ _turn(yaw) for yaw in yaws_deg]
    placed = np.stack([local @ pose[:3, :3].T + pose[:3, 3] for pose in poses])  # (Y, n, 3)
    steps = np.ascontiguousarray(steps, dtype=np.float64)
    points = located.by_height
    counts = shift_counts(np.ascontiguousarray(placed, dtype=np.float64), steps, bool(np.all(np.diff(steps) > 0)),
                          points, np.ascontiguousarray(points[:, 2]), float(support), float(support) * float(support))
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


def load_kernels() -> None:
    """Load the compiled count (:mod:`bim2rdt.verify.kernels`) now: numba's import and its cached machine code,
    which the first plan search would otherwise pay (verify's setup calls this, as it loads registration's)."""
    best_shift(np.zeros((1, 3)), np.eye(4), [0.0], np.array([-0.05, 0.0, 0.05]), Located(np.zeros((1, 3))), 0.04)
