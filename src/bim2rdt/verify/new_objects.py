"""New objects: what neither the building nor a planned object explains, in clusters.

The located points the permanent structure leaves, less those on a checked planned object's surface (at the
pose kept for it), are thinned on a voxel grid and linked when closer than ``link`` m; a cluster large enough
and standing above the slab is an object the BIM lacks (family "unknown": no detector named it). Its pose is
the centre of its box on the slab, level.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pydantic import BaseModel, ConfigDict
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from bim2rdt.bim import BimModel
from bim2rdt.localization import voxel_means
from bim2rdt.perception import Observation, UNKNOWN_FAMILY
from bim2rdt.registration import any_within
from bim2rdt.verify.bodies import body_samples


class NewObjectConfig(BaseModel):
    """Knobs of the new-object clusters (metres)."""

    model_config = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)

    voxel: float = 0.03
    link: float = 0.07
    """Thinned points closer than this are one object."""
    min_points: int = 150
    """Clusters of fewer thinned points (~0.14 m^2 of surface at 3 cm) are clutter too small to report."""
    min_height: float = 0.1
    """Clusters whose top is less than this above the slab are floor noise, cables, a rug."""
    on_planned: float = 0.06
    """Points this close to a checked planned object's surface are that object's."""


@dataclass(frozen=True)
class NewCluster:
    """One cluster of one frame: its observation (family "unknown", pose on the slab), a thinned sample of its
    points (K, 3, world metres, for the motion test) and its box: ``low`` and ``high`` corners (3,) in metres."""

    observation: Observation
    sample: np.ndarray
    low: np.ndarray
    high: np.ndarray
    slab: float
    transient: str = ""
    """Why the cluster is not an object ("" when it may be one): a person, or a thing that moved."""
    frames: tuple[int, ...] = field(default=())

    @property
    def height(self) -> float:
        """How high its top stands above the slab, m."""
        return float(self.high[2] - self.slab)

    @property
    def width(self) -> float:
        """Its largest horizontal extent, m."""
        return float(max(self.high[0] - self.low[0], self.high[1] - self.low[1]))


def new_objects(points_world: np.ndarray, kept: list[tuple[str, np.ndarray]], model: BimModel, slab: float,
                frame_index: int, config: NewObjectConfig = NewObjectConfig()) -> list[Observation]:
    """Observations of the objects the BIM lacks among ``points_world`` (located, structure removed); ``kept``:
    (GlobalId, pose kept for it) of the planned objects checked in this frame."""
    return [c.observation for c in new_clusters(points_world, kept, model, slab, frame_index, config)]


def new_clusters(points_world: np.ndarray, kept: list[tuple[str, np.ndarray]], model: BimModel, slab: float,
                 frame_index: int, config: NewObjectConfig = NewObjectConfig()) -> list[NewCluster]:
    """The clusters of :func:`new_objects`, with their points and boxes, largest first."""
    points = voxel_means(points_world, config.voxel) if len(points_world) else points_world
    for global_id, pose in kept:
        if len(points) == 0:
            break
        body, _ = body_samples(model, global_id, 3000, 0)
        points = points[~any_within(body @ pose[:3, :3].T + pose[:3, 3], points, config.on_planned)]
    if len(points) < config.min_points:
        return []
    pairs = cKDTree(points).query_pairs(config.link, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(points), len(points)))
    count, labels = connected_components(graph, directed=False)
    out = []
    sizes = np.bincount(labels, minlength=count)
    for label in np.flatnonzero(sizes >= config.min_points):  # a frame's leftovers make hundreds of tiny components
        members = points[labels == label]
        if members[:, 2].max() - slab < config.min_height:
            continue
        low, high = members.min(axis=0), members.max(axis=0)
        pose = np.eye(4)
        pose[:3, 3] = [(low[0] + high[0]) / 2, (low[1] + high[1]) / 2, slab]
        observation = Observation(UNKNOWN_FAMILY, None, pose, 0.0, 1.0, len(members), score=1.0,
                                  detector="cluster", frames=(frame_index,), bbox=None)
        out.append(NewCluster(observation, members[:: max(1, len(members) // 300)], low, high, slab,
                              frames=(frame_index,)))
    return sorted(out, key=lambda c: -c.observation.points)
