"""The geometric detector: scan-vs-BIM, no weights. What is in the frame that the BIM's building does not explain,
and which of the BIM's families is it?

1. back-project the depth (every ``stride``-th pixel, flying pixels filtered) to world points;
2. remove what the BIM's permanent elements explain (their surfaces by ray casting, and the storey's slab at
   the height the BIM gives it; then what the rays leave by its 3-D distance to their triangles, for the
   silhouettes): :mod:`bim2rdt.perception.background`;
3. cluster the rest on the image grid: :mod:`bim2rdt.perception.clusters`;
4. give each cluster an image ROI and a mask (its pixels, dilated by one);
5. name it by registration against the candidate families, near ones first: :mod:`bim2rdt.perception.naming`.
"""

from __future__ import annotations

import time
from functools import lru_cache

import cv2
import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from scipy.spatial import cKDTree

from bim2rdt.bim import BimModel
from bim2rdt.perception.camera import Intrinsics
from bim2rdt.perception.background import explained, structure_for
from bim2rdt.perception.clusters import Cluster, grid_clusters
from bim2rdt.perception.detection import Detection
from bim2rdt.perception.edges import EdgeFilter
from bim2rdt.perception.frame import Frame
from bim2rdt.perception.library import library_for
from bim2rdt.perception.naming import Naming, NamingConfig, name_cluster
from bim2rdt.perception.observation import UNKNOWN_FAMILY
from bim2rdt.perception.slab import SLAB_CLEARANCE
from bim2rdt.perception.visibility import DepthView
from bim2rdt.semantics import KnowledgeBasePriors, UprightPrior


class GeometricConfig(BaseModel):
    """Knobs of the geometric detector (lengths in metres)."""

    model_config = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)

    stride: int = 2
    """Work on every n-th pixel in each direction (2: a VGA frame is 320 x 240 points)."""
    surface_tolerance: float = 0.02
    """A point this close to a BIM surface (plus 3 sigma of depth noise along its normal) is the BIM's: what
    as-built walls stray from the model by (a slab's points are judged by ``slab_clearance`` too)."""
    slab_clearance: float = SLAB_CLEARANCE
    link_pixels: float = 3.0
    """Neighbouring grid points link when closer than this many grid spacings (at their depth) ..."""
    link_min: float = 0.04
    """... or than this, whichever is larger."""
    merge_gap: float = 0.08
    """Clusters whose points come this close in space are one object split in the image."""
    min_points: int = 40
    """Clusters of fewer grid points are noise (40 points at stride 2 is ~160 pixels)."""
    min_height: float = 0.05
    """Clusters whose top is less than this above the slab are dirt, cables, the slab's own noise."""
    max_splits: int = 2
    """How often a cluster holding touching objects may be split (each split names one of them)."""
    part_of: float = 0.15
    """A leftover piece mostly this close to the named object is its own (rim, noise), not another object; one
    no family explains is its own within twice that."""
    noise: EdgeFilter = Field(default_factory=EdgeFilter)
    naming: NamingConfig = Field(default_factory=NamingConfig)


class GeometricDetector:
    """Scan-vs-BIM detection (see the module docs): what the depth shows that the BIM's building does not explain,
    clustered and named by the model's families. ``timings`` holds the CPU seconds each stage took on the last
    frame.

    Args:
        model: The BIM, loaded with geometry: its building explains the background, its families name objects.
        priors: {family: upright prior}; None takes the offline knowledge base's for the model's families.
        config: Thresholds of the stages.
    """

    name = "geometric"

    def __init__(self, model: BimModel, priors: dict[str, UprightPrior] | None = None,
                 config: GeometricConfig = GeometricConfig()) -> None:
        self.model, self.config = model, config
        self.library = library_for(model)
        self.structure = structure_for(model)
        self.priors = priors if priors is not None else KnowledgeBasePriors().priors(sorted(self.library.families))
        self.timings: dict[str, float] = {}

    def detect(self, frame: Frame) -> list[Detection]:
        """Find the objects in a localized frame.

        Args:
            frame: An RGB-D frame with ``T_world_camera`` (depth in metres).

        Returns:
            One detection per cluster of unexplained depth that is large enough, with family, bbox and mask.

        Raises:
            PerceptionError: The frame has no pose.
        """
        frame.require_pose("the geometric detector")
        clock = _Clock()
        depth = self.config.noise.apply(frame.depth)
        points, valid = self._points(frame, depth)
        clock.lap("back-project")
        slab = self.structure.slab_height(frame.T_world_camera[:3, 3])
        candidate = valid & ~self._explained(frame, points, valid, slab)
        clock.lap("background")
        clusters = [c for c in grid_clusters(candidate, points, self._link(frame, points), self.config.merge_gap)
                    if self._large_enough(c, slab)]
        clock.lap("cluster")
        view = DepthView(depth, frame.intrinsics, frame.T_world_camera)
        detections = []
        for k, cluster in enumerate(clusters):
            detections += self._detections(frame, view, cluster, slab, k, splits=self.config.max_splits)
        clock.lap("name")
        self.timings = clock.laps
        return detections

    def _points(self, frame: Frame, depth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World points (h, w, 3) of the stride grid and whether each has a usable depth (h, w)."""
        s = self.config.stride
        depth = depth[::s, ::s].astype(np.float64)
        rays = _grid_rays(frame.intrinsics, s)
        T = frame.T_world_camera
        points = (rays * depth[..., None]) @ T[:3, :3].T + T[:3, 3]
        return points, np.isfinite(depth) & (depth > 0)

    def _explained(self, frame: Frame, points: np.ndarray, valid: np.ndarray, slab: float) -> np.ndarray:
        s = self.config.stride
        origin = frame.T_world_camera[:3, 3]
        directions = _grid_rays(frame.intrinsics, s)[valid] @ frame.T_world_camera[:3, :3].T
        depth = (points[valid] - origin) @ frame.T_world_camera[:3, 2]
        noise = self.config.noise
        sigma = noise.noise + noise.noise_per_metre * depth
        out = np.zeros(valid.shape, dtype=bool)
        out[valid] = explained(self.structure, origin, directions, depth, self.config.surface_tolerance, sigma, slab,
                               self.config.slab_clearance)
        return out

    def _link(self, frame: Frame, points: np.ndarray) -> np.ndarray:
        depth = np.nan_to_num((points - frame.T_world_camera[:3, 3]) @ frame.T_world_camera[:3, 2])
        spacing = self.config.stride * depth / frame.intrinsics.fx
        return np.maximum(self.config.link_min, self.config.link_pixels * spacing)

    def _large_enough(self, cluster: Cluster, slab: float) -> bool:
        return len(cluster) >= self.config.min_points and \
            float(np.percentile(cluster.points_world[:, 2], 99.0)) - slab >= self.config.min_height

    def _detections(self, frame: Frame, view: DepthView, cluster: Cluster, slab: float, seed: int,
                    splits: int) -> list[Detection]:
        """The cluster named; when the named object leaves a cluster's worth of its points unexplained (two
        objects touching), its part is one detection and the rest is clustered and named again (at most
        ``splits`` times)."""
        naming = name_cluster(cluster.points_world, view, slab, self.library, self.priors, self.config.naming,
                              seed=seed)
        if naming.family == UNKNOWN_FAMILY or splits <= 0:
            return [self._detection(frame, cluster, naming)]
        model = self.library.families[naming.family]
        inside = _near_model(cluster.points_world, naming.fit.pose, model.tree(self.config.naming.samples),
                             self.config.naming.icp.score_distance)
        if inside.sum() < self.config.min_points or (~inside).sum() < self.config.min_points:
            return [self._detection(frame, cluster, naming)]
        tree, own, others = model.tree(self.config.naming.samples), inside.copy(), []
        for rest in self._regroup(frame, _subset(cluster, ~inside), slab):
            if _near_model(rest.points_world, naming.fit.pose, tree, self.config.part_of).mean() >= 0.5:
                own |= _members(cluster, rest)  # the object's own fringe (a flying-pixel rim, a corner off the mesh)
            else:
                others.append(rest)
        out = []
        for rest in others:
            found = self._detections(frame, view, rest, slab, seed + 1, splits - 1)
            if len(found) == 1 and found[0].family == UNKNOWN_FAMILY and \
                    _near_model(rest.points_world, naming.fit.pose, tree, 2 * self.config.part_of).mean() >= 0.5:
                own |= _members(cluster, rest)  # nothing else explains it, and it hugs the object: the object's
            else:
                out += found
        return [self._detection(frame, _subset(cluster, own), naming)] + out

    def _regroup(self, frame: Frame, rest: Cluster, slab: float) -> list[Cluster]:
        """The leftover points of a split cluster, clustered again (they may be several pieces)."""
        s = self.config.stride
        h, w = -(-frame.intrinsics.height // s), -(-frame.intrinsics.width // s)
        candidate = np.zeros((h, w), dtype=bool)
        candidate[rest.rows, rest.cols] = True
        points = np.zeros((h, w, 3))
        points[rest.rows, rest.cols] = rest.points_world
        link = self._link(frame, points)
        return [c for c in grid_clusters(candidate, points, link, self.config.merge_gap) if self._large_enough(c, slab)]

    def _detection(self, frame: Frame, cluster: Cluster, naming: Naming) -> Detection:
        mask = self._mask(frame, cluster)
        vs, us = np.nonzero(mask)
        bbox = (int(us.min()), int(vs.min()), int(us.max()) + 1, int(vs.max()) + 1)
        return Detection(naming.family, station=None, label=_label(naming, self.priors), bbox=bbox, mask=mask,
                         score=naming.score, detector=self.name,
                         pose=naming.fit.pose if naming.family != UNKNOWN_FAMILY else None)

    def _mask(self, frame: Frame, cluster: Cluster) -> np.ndarray:
        """The cluster's pixels at full resolution: each grid point's block, dilated by one pixel."""
        s = self.config.stride
        small = np.zeros((-(-frame.intrinsics.height // s), -(-frame.intrinsics.width // s)), dtype=np.uint8)
        small[cluster.rows, cluster.cols] = 1
        full = np.kron(small, np.ones((s, s), dtype=np.uint8))[: frame.intrinsics.height, : frame.intrinsics.width]
        return cv2.dilate(full, np.ones((3, 3), np.uint8)).astype(bool)


def _near_model(points_world: np.ndarray, T_world_model: np.ndarray, samples: cKDTree, distance: float) -> np.ndarray:
    """(N,) bool: points within ``distance`` m of the model's surface samples (a k-d tree, body frame) posed at
    ``T_world_model``."""
    body = (points_world - T_world_model[:3, 3]) @ T_world_model[:3, :3]
    gaps, _ = samples.query(body, distance_upper_bound=distance)
    return np.isfinite(gaps)


def _members(cluster: Cluster, part: Cluster) -> np.ndarray:
    """(N,) bool: which of ``cluster``'s grid points are in ``part`` (a subset of it)."""
    width = int(max(cluster.cols.max(), part.cols.max())) + 1
    return np.isin(cluster.rows * width + cluster.cols, part.rows * width + part.cols)


def _subset(cluster: Cluster, keep: np.ndarray) -> Cluster:
    return Cluster(cluster.rows[keep], cluster.cols[keep], cluster.points_world[keep])


@lru_cache(maxsize=8)
def _grid_rays(intrinsics: Intrinsics, stride: int) -> np.ndarray:
    """Camera rays (h, w, 3) with z = 1 of every ``stride``-th pixel (cached: a camera's rays never change)."""
    rays = intrinsics.pixel_rays()[::stride, ::stride].copy()
    rays.setflags(write=False)
    return rays


def _label(naming: Naming, priors: dict[str, UprightPrior]) -> str:
    if naming.family == UNKNOWN_FAMILY:
        return UNKNOWN_FAMILY
    prior = priors.get(naming.family)
    return prior.label if prior else naming.family


class _Clock:
    """CPU seconds of this process per named stage: what a stage costs on one core, whoever else shares it."""

    def __init__(self) -> None:
        self.laps: dict[str, float] = {}
        self._last = time.process_time()

    def lap(self, stage: str) -> None:
        now = time.process_time()
        self.laps[stage] = self.laps.get(stage, 0.0) + now - self._last
        self._last = now
