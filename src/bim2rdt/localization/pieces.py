"""The free-standing things in a view, found without a pose: what the view score counts whole or not at all.

A person, a barrow, a stack of boards or a column stands apart from the walls: above the floor its points form a
connected piece of the cloud, small enough to be one thing. The floor (the points within ``floor`` m of it, after
gravity has levelled the cloud) is left out of the linking, so a thing standing on it stays apart from the walls
the floor runs to. A point links to those of its eight nearest that lie within ``link`` m of it, or within twice the spacing
of the sparser one's surface (:data:`SPACING_FACTOR`; the thinned cloud is a few centimetres apart on a surface
near the sensor: a person standing farther than ``link`` from a wall is a piece of their own there). A
connected piece whose points all lie within ``extent`` m across (twice the farthest point from its centroid) is a
thing; a larger one (walls joined at their corners, a ceiling and what hangs from it) is not, and is counted point
by point.

Why it matters (:mod:`.view_score`): at the true place a person's points lie in free space and earn nothing, but
at a wrong place part of them may land on a column or a wall's end, and earn that place what the truth cannot.
A permanent thing the model has is explained whole at the true place; a thing explained only in part is no
evidence for that place.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

LINK_NEIGHBOURS = 8
"""A point links to those of its nearest this many that are within reach (a kd-tree query, not every pair)."""
SPACING_NEIGHBOUR = 3
"""A point's spacing is the distance to its third nearest neighbour: how densely its surface was sampled."""
SPACING_FACTOR = 2.0
"""Two points link within twice the larger of their spacings (at least ``link``): a sparsely sampled far wall (a
cloud thinned to its cap) stays one piece, not many small ones."""
MAX_LINK_FACTOR = 3.0
"""... and at most three times ``link``: a stray return is not joined across a room."""

NOT_A_THING = -1
"""The label of a point on the floor or in a piece too large to be one thing."""


def free_standing(points: np.ndarray, height: np.ndarray, link: float, floor: float, extent: float) -> np.ndarray:
    """The piece each point belongs to, when that piece is a free-standing thing (see the module's note).

    Args:
        points: (N, 3) points, metres (any frame: only distances are used).
        height: (N,) each point's height above the floor, metres.
        link: Two points within this distance belong to one piece (farther where the cloud is sparse: the module's
            note), m.
        floor: Points lower than this above the floor are the floor: they link nothing, m.
        extent: A piece no larger than this across is a thing, m.

    Returns:
        (N,) labels: 0, 1, ... the thing a point belongs to, :data:`NOT_A_THING` for the floor and large pieces.
    """
    labels = np.full(len(points), NOT_A_THING)
    above = np.flatnonzero(np.asarray(height) >= floor)
    if len(above) == 0:
        return labels
    lifted = np.ascontiguousarray(points[above], dtype=np.float64)
    k = min(LINK_NEIGHBOURS + 1, len(lifted))
    gap, near = cKDTree(lifted).query(lifted, k=k)
    spacing = gap[:, min(SPACING_NEIGHBOUR, k - 1)]
    reach = np.clip(SPACING_FACTOR * spacing, link, MAX_LINK_FACTOR * link)
    linked = gap[:, 1:] < np.maximum(reach[:, None], reach[near[:, 1:]])
    rows = np.repeat(np.arange(len(lifted)), k - 1).reshape(-1, k - 1)[linked]
    graph = coo_matrix((np.ones(len(rows)), (rows, near[:, 1:][linked])), shape=(len(above), len(above)))
    count, piece = connected_components(graph, directed=False)
    size = np.bincount(piece, minlength=count)
    centroid = np.stack([np.bincount(piece, lifted[:, k], minlength=count) for k in range(3)], axis=1) / size[:, None]
    radius = np.zeros(count)
    np.maximum.at(radius, piece, np.linalg.norm(lifted - centroid[piece], axis=1))
    thing = 2.0 * radius <= extent
    number = np.cumsum(thing) - 1  # things numbered 0, 1, ... in piece order
    labels[above] = np.where(thing[piece], number[piece], NOT_A_THING)
    return labels
