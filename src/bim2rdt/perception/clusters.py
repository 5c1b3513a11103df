"""Euclidean clusters of the points the BIM does not explain, found on the image grid.

Two neighbouring pixels (8-connected) belong together when their world points lie within the link distance;
connected components of that graph are the clusters (linear in the number of pixels, unlike a k-d tree radius
search). Parts of one object that an occluder splits in the image (a tripod leg behind a worker's arm) are
joined again when their points come within ``merge_gap`` in space.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

_NEIGHBOURS = ((0, 1), (1, 0), (1, 1), (1, -1))


@dataclass(frozen=True)
class Cluster:
    """Grid pixels (rows, cols) of one cluster and their world points (N, 3)."""

    rows: np.ndarray
    cols: np.ndarray
    points_world: np.ndarray

    def __len__(self) -> int:
        return len(self.rows)


def grid_clusters(candidate: np.ndarray, points_world: np.ndarray, link: np.ndarray,
                  merge_gap: float) -> list[Cluster]:
    """Clusters of the ``candidate`` pixels (h, w) bool with world points (h, w, 3), neighbours linked when
    closer than ``link`` (h, w) m; components within ``merge_gap`` m of each other are merged."""
    h, w = candidate.shape
    index = np.full((h, w), -1)
    rows, cols = np.nonzero(candidate)
    index[rows, cols] = np.arange(len(rows))
    if len(rows) == 0:
        return []
    sources, targets = [], []
    for dr, dc in _NEIGHBOURS:
        a, b = _shifted_pairs(index, dr, dc)
        ok = (a >= 0) & (b >= 0)
        a, b = a[ok], b[ok]
        flat = points_world[rows, cols]
        close = np.linalg.norm(flat[a] - flat[b], axis=1) < np.minimum(link[rows[a], cols[a]], link[rows[b], cols[b]])
        sources.append(a[close])
        targets.append(b[close])
    graph = coo_matrix((np.ones(sum(map(len, sources))), (np.concatenate(sources), np.concatenate(targets))),
                       shape=(len(rows), len(rows)))
    _, labels = connected_components(graph, directed=False)
    labels = _merge_close(labels, points_world[rows, cols], merge_gap)
    return [Cluster(rows[labels == k], cols[labels == k], points_world[rows[labels == k], cols[labels == k]])
            for k in np.unique(labels)]


def _shifted_pairs(index: np.ndarray, dr: int, dc: int) -> tuple[np.ndarray, np.ndarray]:
    h, w = index.shape
    a = index[: h - dr, max(0, -dc): w - max(0, dc)]
    b = index[dr:, max(0, dc): w + min(0, dc)]
    return a.ravel(), b.ravel()


def _merge_close(labels: np.ndarray, points: np.ndarray, gap: float, min_size: int = 3) -> np.ndarray:
    """Union of components whose points come within ``gap`` m (components of fewer than ``min_size`` points
    are noise and left alone)."""
    ids, counts = np.unique(labels, return_counts=True)
    big = ids[counts >= min_size]
    if len(big) < 2 or gap <= 0:
        return labels
    members = {k: _thinned(points[labels == k]) for k in big}
    boxes = {k: (members[k].min(axis=0), members[k].max(axis=0)) for k in big}
    trees: dict = {}
    parent = {k: k for k in ids}
    for i, a in enumerate(big):
        for b in big[i + 1:]:
            if _boxes_apart(boxes[a], boxes[b], gap):
                continue
            tree = trees.setdefault(a, cKDTree(members[a]))
            if np.isfinite(tree.query(members[b], distance_upper_bound=gap)[0]).any():
                parent[_root(parent, b)] = _root(parent, a)
    return np.array([_root(parent, k) for k in labels])


def _thinned(points: np.ndarray, most: int = 1500) -> np.ndarray:
    """Every n-th point, at most ``most`` of them: neighbouring grid points are a centimetre or two apart, far
    below any merge gap, so a thinned cluster answers 'within the gap?' as well as the whole one."""
    return points[:: max(1, -(-len(points) // most))]


def _boxes_apart(a, b, gap: float) -> bool:
    return bool(np.any(a[0] - gap > b[1]) or np.any(b[0] - gap > a[1]))


def _root(parent: dict, k):
    while parent[k] != k:
        parent[k] = parent[parent[k]]
        k = parent[k]
    return k
