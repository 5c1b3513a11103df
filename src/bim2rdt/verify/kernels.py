"""The plan search's exact count, compiled (numba): for every turn and shift of the scan, how many of the object's
posed samples have a located point within ``support`` (:func:`bim2rdt.verify.shift_search.best_shift`).

A k-d tree query per posed sample (decision 0039: 441 shifts x ~350 samples on the coarse grid, 5 turns x 81 on the
fine one, pruned by an occupancy bound) cost ~0.15 s of an office1 frame. Here each sample is taken once per turn:
the located points within ``support`` of it in height (points sorted by z, two binary searches), then for each
such point the box of shifts that could bring the sample within ``support`` of it (a superset, found by binary
search in the sorted steps), each shift tested exactly. The test is pykdtree's, operation for operation: the
shifted sample ``(q + s)``, the squared distance summed x, y, z from 0 as ``(q + s) - p`` squared, a hit when it is
below ``support * support`` (pykdtree's ``dist < dub`` and its result's ``>= dub`` miss); no fused multiply-add
(numba leaves them off without ``fastmath``). So the counts are the full scan's, bit for bit, and the first of the
highest is its answer. Compiled once per machine and cached next to this file (``cache=True``).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def shift_counts(placed, steps, sorted_steps, points, heights, support, bound):  # pragma: no cover - compiled
    """(Y * S,) covered samples of every candidate, turn-major, then shifts x-major (``s = ix * m + iy``).

    Args:
        placed: (Y, n, 3) the samples posed at each turn, metres.
        steps: (m,) shifts along each of x and y, metres.
        sorted_steps: ``steps`` ascend strictly (the shift boxes are found by binary search; else all shifts).
        points: (P, 3) located points sorted by height.
        heights: (P,) their heights (``points[:, 2]``), ascending.
        support: A sample nearer than this to a point is covered, metres.
        bound: ``support * support`` as Python computes it (pykdtree's squared bound).

    Returns:
        The counts.
    """
    turns, n = placed.shape[0], placed.shape[1]
    m = len(steps)
    shifts = m * m
    counts = np.zeros(turns * shifts, np.int64)
    covered = np.zeros(shifts, np.bool_)
    margin = 1e-9 + 1e-9 * support  # the boxes and the height window a little wide: the exact test decides
    lowest, highest = steps.min(), steps.max()
    for t in range(turns):
        for i in range(n):
            covered[:] = False
            qx, qy, qz = placed[t, i, 0], placed[t, i, 1], placed[t, i, 2]
            first = np.searchsorted(heights, qz - support - margin)
            last = np.searchsorted(heights, qz + support + margin, side="right")
            for j in range(first, last):
                px, py, pz = points[j, 0], points[j, 1], points[j, 2]
                if (px - qx < lowest - support - margin or px - qx > highest + support + margin
                        or py - qy < lowest - support - margin or py - qy > highest + support + margin):
                    continue
                x0, x1, y0, y1 = 0, m, 0, m
                if sorted_steps:
                    x0 = np.searchsorted(steps, px - qx - support - margin)
                    x1 = np.searchsorted(steps, px - qx + support + margin, side="right")
                    y0 = np.searchsorted(steps, py - qy - support - margin)
                    y1 = np.searchsorted(steps, py - qy + support + margin, side="right")
                for ix in range(x0, x1):
                    for iy in range(y0, y1):
                        s = ix * m + iy
                        if covered[s]:
                            continue
                        dx = (qx + steps[ix]) - px
                        dy = (qy + steps[iy]) - py
                        dz = (qz + 0.0) - pz
                        distance = 0.0
                        distance += dx * dx
                        distance += dy * dy
                        distance += dz * dz
                        if distance < bound:
                            covered[s] = True
            base = t * shifts
            for s in range(shifts):
                if covered[s]:
                    counts[base + s] += 1
    return counts
