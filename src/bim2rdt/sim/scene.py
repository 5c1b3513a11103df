"""A synthetic site: BIM objects (meshes in their body frames) placed on a tiled ground plane.

Objects are upright along +z in their body frames (see :mod:`bim2rdt.sim.meshes`); ``T_world_model`` places
them. Surfaces carry a procedural texture (grime, stencils, plank joints: 8 cm cells of varying albedo, fixed
to the body) so a corner detector finds corners ON the surfaces, as it does on real, dirty site objects.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import trimesh

from bim2rdt.registration.so3 import axis_angle

GROUND = -2
"""Label of ground pixels in a rendered frame (misses are -1, objects their index)."""
MISS = -1


@dataclass(frozen=True)
class PlacedObject:
    """One BIM object on site: its family, body-frame mesh, true pose (4x4, metres) and base albedo (0-1)."""

    family: str
    mesh: trimesh.Trimesh
    T_world_model: np.ndarray
    albedo: float = 0.5


@dataclass
class SiteScene:
    """Objects on a square ground plane of ``ground_size`` metres at z = 0, as one ray-castable mesh."""

    objects: list[PlacedObject]
    ground_size: float = 30.0
    _mesh: trimesh.Trimesh | None = field(default=None, init=False, repr=False)
    _face_owner: np.ndarray | None = field(default=None, init=False, repr=False)

    def mesh(self) -> tuple[trimesh.Trimesh, np.ndarray]:
        """The world mesh and, per face, the index of the object it belongs to (``GROUND`` for the ground)."""
        if self._mesh is None:
            parts = [_ground(self.ground_size)] + [o.mesh.copy().apply_transform(o.T_world_model)
                                                    for o in self.objects]
            owners = [np.full(len(p.faces), owner) for owner, p in zip([GROUND, *range(len(self.objects))], parts)]
            self._mesh = trimesh.util.concatenate(parts)
            self._face_owner = np.concatenate(owners)
        return self._mesh, self._face_owner


def ground_pose(x: float, y: float, yaw_rad: float) -> np.ndarray:
    """T_world_model of an upright object standing on the slab at (x, y) m, turned by ``yaw_rad`` about +z."""
    T = np.eye(4)
    T[:3, :3] = axis_angle(np.array([0.0, 0.0, 1.0]), np.array(yaw_rad))
    T[:3, 3] = (x, y, 0.0)
    return T


def _ground(size: float) -> trimesh.Trimesh:
    half = size / 2
    vertices = np.array([[-half, -half, 0.0], [half, -half, 0.0], [half, half, 0.0], [-half, half, 0.0]])
    return trimesh.Trimesh(vertices, np.array([[0, 1, 2], [0, 2, 3]]), process=False)


def texture(points_body: np.ndarray, cell: float = 0.08, contrast: float = 0.25) -> np.ndarray:
    """Albedo factor in [1 - contrast, 1] of 3-D cells of ``cell`` metres: a deterministic hash of the cell."""
    ijk = np.floor(points_body / cell).astype(np.int64)
    hashed = (ijk[:, 0] * 73856093) ^ (ijk[:, 1] * 19349663) ^ (ijk[:, 2] * 83492791)
    return 1.0 - contrast * (np.abs(hashed) % 1009) / 1008.0


def ground_albedo(points_world: np.ndarray) -> np.ndarray:
    """Concrete slab: 1 m bays with dark joints and 20 cm grime patches."""
    joints = np.any(np.abs(points_world[:, :2] - np.round(points_world[:, :2])) < 0.01, axis=1)
    return np.where(joints, 0.3, 0.45 * texture(points_world, cell=0.2, contrast=0.25))
