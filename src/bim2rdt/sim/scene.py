"""A synthetic site: BIM objects (meshes in their body frames) placed on a tiled ground plane, and optionally the
building itself (the IFC's walls, slabs, columns and doors, in world coordinates) and workers walking through.

Objects are upright along +z in their body frames (see :mod:`bim2rdt.sim.meshes`); ``T_world_model`` places
them. Surfaces carry a procedural texture (grime, stencils, plank joints: 8 cm cells of varying albedo, fixed
to the body) so a corner detector finds corners ON the surfaces, as it does on real, dirty site objects. The
building's surfaces carry their own (block joints, formwork ties, slab bays; see :mod:`bim2rdt.sim.surfaces`).

A scene with neither building, workers nor colours renders exactly as it always has (grey, the registration
scenarios S1-S4 depend on that); colour and building make the renderer produce RGB as well.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import trimesh

from bim2rdt import exact
from bim2rdt.frames import UP
from bim2rdt.registration.sampling import unit_face_normals
from bim2rdt.registration.so3 import axis_angle

GROUND = -2
"""Label of ground pixels in a rendered frame (misses are -1, objects their index)."""
MISS = -1
STRUCTURE = -3
"""Label of pixels on the building's permanent elements (``RgbdFrame.part`` says which one)."""
WORKER = -4
"""Label of pixels on a worker (``RgbdFrame.part`` says which one)."""

Colour = tuple[float, float, float]
"""Diffuse RGB reflectance, each 0-1."""


@dataclass(frozen=True)
class PlacedObject:
    """One BIM object on site: its family, body-frame mesh, true pose (4x4, metres) and base albedo (0-1);
    ``colour`` (RGB 0-1) tints it when given (None: grey of ``albedo``)."""

    family: str
    mesh: trimesh.Trimesh
    T_world_model: np.ndarray
    albedo: float = 0.5
    colour: Colour | None = None


@dataclass(frozen=True)
class BuildingPart:
    """A permanent element of the building as the IFC models it: GlobalId, IFC class, world mesh (metres), its
    surface colour (RGB 0-1) and the surface ``finish`` that textures it (see :mod:`bim2rdt.sim.surfaces`)."""

    global_id: str
    ifc_class: str
    mesh: trimesh.Trimesh
    colour: Colour
    finish: str = "concrete"


@dataclass
class SiteScene:
    """Objects on a square ground plane of ``ground_size`` metres at z = 0 (0 = no ground plane: the building's
    slab is the floor), the ``building``'s parts and ``workers`` (placed meshes), as one ray-castable mesh."""

    objects: list[PlacedObject]
    ground_size: float = 30.0
    building: list[BuildingPart] = field(default_factory=list)
    workers: list[PlacedObject] = field(default_factory=list)
    _mesh: trimesh.Trimesh | None = field(default=None, init=False, repr=False)
    _face_owner: np.ndarray | None = field(default=None, init=False, repr=False)
    _face_part: np.ndarray | None = field(default=None, init=False, repr=False)
    _face_normals: np.ndarray | None = field(default=None, init=False, repr=False)

    @property
    def coloured(self) -> bool:
        """Whether frames of this scene carry RGB (a building, workers or a tinted object), not only grey."""
        return bool(self.building or self.workers or any(o.colour is not None for o in self.objects))

    def mesh(self) -> tuple[trimesh.Trimesh, np.ndarray]:
        """The scene's world mesh (built once).

        Returns:
            (the mesh in world metres, per face its owner: the object index, ``GROUND``, ``STRUCTURE`` or
                ``WORKER``).
        """
        if self._mesh is None:
            self._build()
        return self._mesh, self._face_owner

    def face_parts(self) -> np.ndarray:
        """Which part each face of :meth:`mesh` belongs to.

        Returns:
            Per face, the index of its owner within its kind (object, building part or worker; -1 for the
                ground).
        """
        if self._mesh is None:
            self._build()
        return self._face_part

    def face_normals(self) -> np.ndarray:
        """The unit normals of :meth:`mesh`'s faces, bit-identical on any machine (trimesh's go through BLAS).

        Returns:
            (F, 3) unit normals in the world frame; zero for a degenerate face.
        """
        if self._face_normals is None:
            self._face_normals = unit_face_normals(self.mesh()[0])
        return self._face_normals

    def _build(self) -> None:
        parts: list[tuple[trimesh.Trimesh, int, int]] = []
        if self.ground_size > 0:
            parts.append((_ground(self.ground_size), GROUND, -1))
        parts += [(placed_mesh(o), i, i) for i, o in enumerate(self.objects)]
        parts += [(b.mesh, STRUCTURE, k) for k, b in enumerate(self.building)]
        parts += [(placed_mesh(w), WORKER, k) for k, w in enumerate(self.workers)]
        self._mesh = trimesh.util.concatenate([p for p, _, _ in parts])
        self._face_owner = np.concatenate([np.full(len(p.faces), owner) for p, owner, _ in parts])
        self._face_part = np.concatenate([np.full(len(p.faces), part) for p, _, part in parts])


def placed_mesh(placed: PlacedObject) -> trimesh.Trimesh:
    """The object's mesh in world coordinates, its vertices moved bit-exactly (trimesh's ``apply_transform``
    is a BLAS product)."""
    return trimesh.Trimesh(exact.transform(placed.T_world_model, placed.mesh.vertices), placed.mesh.faces,
                           process=False)


def ground_pose(x: float, y: float, yaw_rad: float) -> np.ndarray:
    """T_world_model of an upright object standing on the slab at (x, y) m, turned by ``yaw_rad`` about +z."""
    T = np.eye(4)
    T[:3, :3] = axis_angle(UP, np.array(yaw_rad))
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
