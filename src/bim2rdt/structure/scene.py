"""What the structure judge casts rays at: the model's bodies (the localization's occluded map: permanent
elements and every other body, so furniture hides the wall behind it), each face owned by its element, and which
of those elements are judged (:data:`PERMANENT_CLASSES`) and which fix the pose (the localization map)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.localization import GRAZING_COS, OccludedMap

PERMANENT_CLASSES: frozenset[str] = frozenset({
    "IfcWall", "IfcWallStandardCase", "IfcWallElementedCase",
    "IfcSlab", "IfcSlabStandardCase", "IfcSlabElementedCase",
    "IfcColumn", "IfcColumnStandardCase", "IfcBeam", "IfcBeamStandardCase",
    "IfcStair", "IfcStairFlight", "IfcRamp", "IfcRampFlight",
    "IfcDoor", "IfcDoorStandardCase", "IfcWindow", "IfcWindowStandardCase",
})
"""The permanent elements judged as built or not: walls, slabs, columns, beams, stairs (and ramps), doors and
windows (IFC2X3's *StandardCase classes included)."""


@dataclass(frozen=True)
class Cast:
    """Rays from one origin: ``t`` (K,) metres to the first model face (inf: none), ``element`` (K,) index into
    :attr:`JudgeScene.ids` (-1: none), ``normal`` (K, 3) unit, turned towards the origin, and ``cos`` (K,) of the
    angle between ray and normal; ``front`` (K,) whether the ray met the face from outside its body (the mesh's
    winding: a ray leaving a body meets its faces from inside)."""

    t: np.ndarray
    element: np.ndarray
    normal: np.ndarray
    cos: np.ndarray
    front: np.ndarray


@dataclass(frozen=True)
class JudgeScene:
    """The occluded map with each face's element: ``ids``/``classes`` of every body, ``judged`` (a permanent
    element) and ``in_map`` (it fixes the pose) per body."""

    occluded: OccludedMap
    ids: tuple[str, ...]
    classes: tuple[str, ...]
    judged: np.ndarray
    in_map: np.ndarray
    face_element: np.ndarray

    @classmethod
    def of(cls, model: BimModel) -> JudgeScene:
        """The scene of ``model`` (its occluded map is built once per model object).

        Args:
            model: The BIM, loaded with geometry.

        Returns:
            The scene.
        """
        occluded = OccludedMap.of(model)
        classes_of = {el.global_id: el.ifc_class for el in model.elements}
        ids = occluded.permanent.element_ids + occluded.occluder_ids
        classes = tuple(classes_of.get(g, "") for g in ids)
        mapped = len(occluded.permanent.element_ids)
        owner = occluded.face_owner
        face_element = np.where(owner >= 0, owner, mapped - 1 - owner)
        judged = np.array([c in PERMANENT_CLASSES for c in classes])
        in_map = np.arange(len(ids)) < mapped
        return cls(occluded, ids, classes, judged, in_map, face_element)

    def cast(self, origin: np.ndarray, directions: np.ndarray) -> Cast:
        """The first model face along each ray (grazing hits, beyond 80 degrees of the normal, count as none).

        Args:
            origin: (3,) world metres.
            directions: (K, 3) unit world directions.

        Returns:
            The rays' :class:`Cast`.
        """
        return self.cast_each(np.broadcast_to(origin, directions.shape), directions)

    def cast_each(self, origins: np.ndarray, directions: np.ndarray) -> Cast:
        """As :meth:`cast`, each ray from its own origin (K, 3).

        Args:
            origins: (K, 3) world metres.
            directions: (K, 3) unit world directions.

        Returns:
            The rays' :class:`Cast` (``t`` from each ray's origin).
        """
        mesh = self.occluded.mesh
        face = mesh.ray.intersects_first(origins, directions)
        t = np.full(len(directions), np.inf)
        element = np.full(len(directions), -1)
        normal = np.zeros((len(directions), 3))
        cos = np.zeros(len(directions))
        front = np.zeros(len(directions), bool)
        hit = face >= 0
        normals = mesh.face_normals[face[hit]]
        towards = np.einsum("ni,ni->n", normals, directions[hit])
        corner = mesh.vertices[mesh.faces[face[hit], 0]]
        with np.errstate(divide="ignore", invalid="ignore"):
            depth = np.einsum("ni,ni->n", normals, corner - origins[hit]) / towards
        good = (np.abs(towards) >= GRAZING_COS) & (depth > 0)
        rows = np.flatnonzero(hit)[good]
        t[rows] = depth[good]
        element[rows] = self.face_element[face[hit][good]]
        normal[rows] = np.where((towards[good] > 0)[:, None], -normals[good], normals[good])
        cos[rows] = np.abs(towards[good])
        front[rows] = towards[good] < 0
        return Cast(t, element, normal, cos, front)
