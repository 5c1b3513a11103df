"""The size of each new object, measured again in the frame that found it: the twin keeps a new object's position
(its cluster's centre on the slab) but not its extent. The report takes that frame's copy (~320 px wide), keeps the
points that stand in front of the BIM (depth residual below ``-IN_FRONT_M``) and above the slab, links them as the
new-object stage does (closer than ``LINK_M``), and measures the cluster nearest the object's position: its extent
in x and y and its height above the slab, metres."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from bim2rdt.twin import ElementState, ElementStatus
from bim2rdt.verify.report.capture import FrameView

IN_FRONT_M = 0.05
"""A point this much nearer than the BIM's surface on its ray is something the BIM lacks."""
ABOVE_SLAB_M = 0.03
LINK_M = 0.07
"""Points closer than this are one object (the new-object stage's ``link``)."""
NEAR_M = 0.3
"""The cluster must hold a point within this distance (horizontal) of the object's position."""
MIN_POINTS = 20


def new_object_sizes(states: Mapping[str, ElementState], frames: Sequence, views: Mapping[int, FrameView],
                     residuals: Mapping[int, np.ndarray]) -> dict[str, tuple[int, np.ndarray]]:
    """GlobalId -> (frame index, (3,) size x, y, z in metres) of each new object a frame that found it measures.

    Args:
        states: The twin's states by GlobalId.
        frames: verify's frame results.
        views: The frames' small copies by index.
        residuals: Each frame's depth residual against the BIM (metres, the copy's size) by index.

    Returns:
        The sizes of the objects a frame could measure.
    """
    poses = {f.index: f.pose for f in frames if f.pose is not None}
    sizes = {}
    for state in states.values():
        if state.status is not ElementStatus.NEW or state.pose is None or state.evidence is None:
            continue
        for index in state.evidence.frames:
            if index in residuals and index in views and index in poses:
                size = measure(views[index], poses[index], residuals[index], state.pose[:3, 3])
                if size is not None:
                    sizes[state.global_id] = (index, size)
                    break
    return sizes


def measure(view: FrameView, T_world_camera: np.ndarray, residual: np.ndarray,
            position: np.ndarray) -> np.ndarray | None:
    """The extent of the cluster at ``position`` in one frame.

    Args:
        view: The frame's copy.
        T_world_camera: Its fixed pose (4x4).
        residual: Its depth residual against the BIM, metres.
        position: The object's position (on the slab), world metres.

    Returns:
        (3,) size x, y and height above ``position``'s z, metres; None when no cluster stands there.
    """
    v, u = np.nonzero(np.nan_to_num(residual, nan=0.0) < -IN_FRONT_M)
    camera = view.intrinsics.backproject(np.stack([u, v], axis=1).astype(float), view.depth[v, u].astype(float))
    points = camera @ T_world_camera[:3, :3].T + T_world_camera[:3, 3]
    points = points[points[:, 2] > position[2] + ABOVE_SLAB_M]
    if len(points) < MIN_POINTS:
        return None
    pairs = cKDTree(points).query_pairs(LINK_M, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(points), len(points)))
    _, labels = connected_components(graph, directed=False)
    gap = np.linalg.norm(points[:, :2] - position[:2], axis=1)
    if gap.min() > NEAR_M:
        return None
    cluster = points[labels == labels[np.argmin(gap)]]
    if len(cluster) < MIN_POINTS:
        return None
    return np.array([np.ptp(cluster[:, 0]), np.ptp(cluster[:, 1]), cluster[:, 2].max() - position[2]])
