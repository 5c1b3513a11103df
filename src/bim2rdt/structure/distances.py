"""Each return's signed distance to the nearest permanent face: the permanent elements' surfaces sampled densely
(a k-d tree of samples with their face normals), the nearest sample's normal turned towards the sensor, and the
return's distance along it (+: in front of the face, towards the sensor; -: behind it). Past a face's edge (the
nearest sample farther aside than a few spacings) the straight distance, with that sign."""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from bim2rdt.bim import BimModel
from bim2rdt.structure.scene import PERMANENT_CLASSES

MAX_SAMPLES = 2_000_000
_CACHE: OrderedDict[tuple[str, int, float], FaceSamples] = OrderedDict()


@dataclass(frozen=True)
class FaceSamples:
    """Points (M, 3) on the permanent faces, metres, their unit ``normals`` (M, 3), a k-d tree over them and the
    ``spacing`` (m) they were drawn at."""

    points: np.ndarray
    normals: np.ndarray
    tree: cKDTree
    spacing: float

    @classmethod
    def of(cls, model: BimModel, spacing: float) -> FaceSamples:
        """The model's permanent faces sampled about ``spacing`` m apart (coarser if that would pass
        :data:`MAX_SAMPLES`), built once per model object and spacing.

        Args:
            model: The BIM, loaded with geometry.
            spacing: Metres between samples.

        Returns:
            The samples.
        """
        key = (model.digest, id(model), spacing)
        if key not in _CACHE:
            _CACHE[key] = cls._build(model, spacing)
            while len(_CACHE) > 4:
                _CACHE.popitem(last=False)
        return _CACHE[key]

    @classmethod
    def _build(cls, model: BimModel, spacing: float) -> FaceSamples:
        meshes = [trimesh.Trimesh(*model.mesh(el.global_id), process=False) for el in model.elements
                  if el.ifc_class in PERMANENT_CLASSES and model.has_mesh(el.global_id)]
        meshes = [m for m in meshes if m.area > 0]
        if not meshes:
            return cls(np.zeros((1, 3)) + np.inf, np.zeros((1, 3)), cKDTree(np.zeros((1, 3)) + 1e9), spacing)
        area = sum(m.area for m in meshes)
        spacing = max(spacing, float(np.sqrt(area / MAX_SAMPLES)))
        points, normals = [], []
        for mesh in meshes:
            sample, face = trimesh.sample.sample_surface(mesh, max(1, int(mesh.area / spacing**2)), seed=0)
            points.append(np.asarray(sample))
            normals.append(np.asarray(mesh.face_normals[face]))
        points = np.concatenate(points)
        return cls(points, np.concatenate(normals), cKDTree(points), spacing)

    def signed(self, points_world: np.ndarray, centre: np.ndarray, far: float) -> np.ndarray:
        """Each point's signed distance (N,) to the nearest permanent face, metres; NaN farther than ``far``.

        Args:
            points_world: (N, 3) returns in the world, metres.
            centre: (3,) the sensor's position (the faces' normals are turned towards it).
            far: Farther than this from every face, a return is not the structure's.

        Returns:
            The distances.
        """
        gap, index = self.tree.query(points_world, distance_upper_bound=far + 3 * self.spacing)
        found = np.isfinite(gap)
        out = np.full(len(points_world), np.nan)
        q, n = self.points[index[found]], self.normals[index[found]]
        n = np.where((np.einsum("ni,ni->n", n, centre - q) < 0)[:, None], -n, n)
        offset = points_world[found] - q
        along = np.einsum("ni,ni->n", n, offset)
        aside = np.linalg.norm(offset - along[:, None] * n, axis=1)
        value = np.where(aside <= 3 * self.spacing, along, np.sign(along) * np.linalg.norm(offset, axis=1))
        out[found] = np.where(np.abs(value) <= far, value, np.nan)
        return out
