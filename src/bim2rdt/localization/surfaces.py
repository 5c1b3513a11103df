"""The map the robot localizes on: the BIM's permanent surfaces, and the part of them a camera can see.

A wall has two faces a wall's thickness apart and a camera sees one of them. Matching depth points to the
nearest of ALL the BIM's surface samples lets an odometry error near a wall's thickness pull the points onto
the face behind (point-to-plane ICP then converges there happily: the back face is as flat as the front). So
the model is sampled the way the camera sees it: the permanent meshes are ray cast from the prior camera pose
(first hit only, over a field of view wider than the camera's), which keeps exactly the faces turned towards
the camera and not hidden behind others; the back of a wall is never in the model.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
import trimesh

from bim2rdt.bim import BimModel, NO_MAP, map_elements
from bim2rdt.localization.errors import LocalizationError, Refusal
from bim2rdt.perception import Intrinsics
from bim2rdt.perception import hit_depths

GRAZING_COS = np.cos(np.deg2rad(80.0))
"""Surfaces seen at more than 80 degrees from their normal are left out: their depth returns are mixed pixels."""
_CACHE_SIZE = 4


@dataclass(frozen=True)
class SurfaceSamples:
    """Visible permanent surface: points (M, 3) world metres, unit normals (M, 3) turned towards the camera,
    and for each the index of its element in :attr:`PermanentMap.element_ids`."""

    points: np.ndarray
    normals: np.ndarray
    owner: np.ndarray


@dataclass(frozen=True)
class PermanentMap:
    """The permanent elements' meshes as one ray-castable world mesh (metres), with each face's element."""

    mesh: trimesh.Trimesh
    face_owner: np.ndarray  # (F,) index into element_ids
    element_ids: tuple[str, ...]
    element_classes: tuple[str, ...]

    @classmethod
    def from_model(cls, model: BimModel) -> PermanentMap:
        """The map of a model; :class:`LocalizationError` when it has no permanent element with a body."""
        if model.meshes is None:
            raise LocalizationError(f"{model.path.name}: loaded without geometry; localizing needs its meshes "
                                    "(load_ifc(path, geometry=True))", Refusal.NO_MAP)
        elements = map_elements(model)
        if not elements:
            raise LocalizationError(f"{model.path.name}: {NO_MAP} (bim2rdt info --readiness --require-map checks a "
                                    "model before a tour)", Refusal.NO_MAP)
        parts = [model.mesh(el.global_id) for el in elements]
        vertices = np.concatenate([v for v, _ in parts])
        offsets = np.cumsum([0] + [len(v) for v, _ in parts[:-1]])
        faces = np.concatenate([f + o for (_, f), o in zip(parts, offsets)])
        owner = np.concatenate([np.full(len(f), k) for k, (_, f) in enumerate(parts)])
        mesh = trimesh.Trimesh(vertices, faces, process=False)
        keep = mesh.area_faces > 1e-12  # degenerate triangles have no normal
        return cls(trimesh.Trimesh(vertices, faces[keep], process=False), owner[keep],
                   tuple(el.global_id for el in elements), tuple(el.ifc_class for el in elements))

    def visible(self, T_world_camera: np.ndarray, intrinsics: Intrinsics, stride: int, margin: float,
                max_range: float) -> SurfaceSamples:
        """The permanent surface seen from ``T_world_camera``: one ray per ``stride``-th pixel of the camera's
        image widened by ``margin`` on each side, first hits within ``max_range`` (m), grazing hits dropped."""
        directions = widened_rays(intrinsics, stride, margin) @ T_world_camera[:3, :3].T
        origin = T_world_camera[:3, 3]
        depth, face = self._cast(origin, directions)
        hit = face >= 0
        face, directions, depth = face[hit], directions[hit], depth[hit]
        normals = self.mesh.face_normals[face]
        towards = np.einsum("ni,ni->n", normals, directions)
        unit = directions / np.linalg.norm(directions, axis=1, keepdims=True)
        cos_incidence = np.abs(np.einsum("ni,ni->n", normals, unit))
        keep = (depth > 0) & (depth <= max_range) & (cos_incidence >= GRAZING_COS)
        normals = np.where((towards > 0)[:, None], -normals, normals)  # face the camera, whatever the winding
        points = origin + directions[keep] * depth[keep, None]
        return SurfaceSamples(points, normals[keep], self.face_owner[face[keep]])


    def first_hit(self, origin: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """Ray parameter t (K,) of the first permanent surface along origin + t * directions (inf: none)."""
        return self._cast(origin, directions)[0]

    def _cast(self, origin: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(t (K,), first face hit (K,), -1 and inf where none) of rays origin + t * directions (embree)."""
        face = self.mesh.ray.intersects_first(np.broadcast_to(origin, directions.shape), directions)
        t, _ = hit_depths(self.mesh, face, origin, directions)  # n . (v0 - origin) / n . d, compiled
        t[face < 0] = np.inf
        return t, face

    def samples(self, spacing: float, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Every permanent surface sampled area-uniformly about ``spacing`` m apart, both faces of every wall:
        (points (N, 3), outward unit normals (N, 3)), world metres. What a plain registration against the BIM
        would use as its map; :meth:`visible` is what this localizer uses."""
        count = max(1, int(self.mesh.area / spacing**2))
        points, face = trimesh.sample.sample_surface(self.mesh, count, seed=seed)
        return np.asarray(points, dtype=np.float64), np.asarray(self.mesh.face_normals[face], dtype=np.float64)


def widened_rays(intrinsics: Intrinsics, stride: int, margin: float) -> np.ndarray:
    """Camera-frame ray directions (z = 1), (K, 3), on a ``stride``-pixel grid over the image widened by
    ``margin`` x its size on each side."""
    u = np.arange(-margin * intrinsics.width, (1 + margin) * intrinsics.width, stride)
    v = np.arange(-margin * intrinsics.height, (1 + margin) * intrinsics.height, stride)
    uu, vv = np.meshgrid(u, v)
    return np.stack([(uu - intrinsics.cx) / intrinsics.fx, (vv - intrinsics.cy) / intrinsics.fy,
                     np.ones(uu.shape)], axis=-1).reshape(-1, 3)


_MAPS: OrderedDict[tuple[str, int], PermanentMap] = OrderedDict()


def permanent_map(model: BimModel) -> PermanentMap:
    """The model's :class:`PermanentMap`, built once per model object (the last few are kept)."""
    key = (model.digest, id(model))
    if key not in _MAPS:
        _MAPS[key] = PermanentMap.from_model(model)
        while len(_MAPS) > _CACHE_SIZE:
            _MAPS.popitem(last=False)
    _MAPS.move_to_end(key)
    return _MAPS[key]
