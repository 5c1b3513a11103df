"""The BIM's planar faces: the permanent meshes' coplanar triangles grouped into planes, kept where a plane holds
enough area of its element to be measured.

The depth check compares angles between measured planes and the BIM's. A plane there must be a real flat face:
a wall's side, a slab's top, a column's face. Grouping by element and orientation alone made a spiral stair's
treads (one orientation, many heights) one "plane", and its least-squares fit met the slab at 62 degrees on a
real sweep whose raw floor-wall angles were 88.9-89.8. So triangles are grouped by their own plane (normal and
offset), and a group is a face only when

- its element is not of a class that is not flat by nature (stairs, ramps, railings: ``non_planar_classes``),
- it holds at least ``min_area`` m^2, and at least ``min_share`` of its element's area: a curved wall tessellated
  into facets, or a stair's treads, have no face that holds a real share of the element.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import trimesh
from pydantic import BaseModel, ConfigDict, Field

NON_PLANAR = ("IfcStair", "IfcStairFlight", "IfcRamp", "IfcRampFlight", "IfcRailing", "IfcDoor", "IfcWindow")
"""Classes that never yield a plane: not flat by nature (stairs, ramps, railings), or a leaf that may stand ajar."""


class PlanarFacesConfig(BaseModel):
    """Which BIM faces the depth check may measure (areas in m^2, lengths in metres):
    ``Settings.verify.faces`` (``BIM2RDT_VERIFY__FACES__*``)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    min_area: float = Field(0.5, gt=0.0, description="A face holds at least this much area, m^2 (a stair tread "
                                                     "~0.25, a column face 0.3 x 2.5 = 0.75).")
    min_share: float = Field(0.1, gt=0.0, le=1.0, description="... and this share of its element's area: a "
                             "column's face holds ~24 %, a facet of a curved wall or a tread of a stair a few %.")
    angle_step_deg: float = Field(2.0, gt=0.0, description="Triangles whose normals agree within about this are "
                                  "one plane, degrees.")
    offset_step: float = Field(0.02, gt=0.0, description="... and whose offsets agree within about this, m.")
    on_face: float = Field(0.02, gt=0.0, description="A surface sample within this of a face's plane (and with its "
                           "normal) lies on that face, m.")
    non_planar_classes: tuple[str, ...] = Field(NON_PLANAR, description="IFC classes that never yield a plane.")


@dataclass(frozen=True)
class PlanarFaces:
    """The faces of a permanent map: per face its element's index (into the map's ``element_ids``), unit normal
    (world, outward), offset (``normal . x = offset``, m) and area (m^2)."""

    owner: np.ndarray
    normal: np.ndarray
    offset: np.ndarray
    area: np.ndarray

    @classmethod
    def of(cls, mesh: trimesh.Trimesh, face_owner: np.ndarray, element_classes: Sequence[str],
           config: PlanarFacesConfig = PlanarFacesConfig()) -> PlanarFaces:
        """The planar faces of a mesh, grouped and filtered (see the module's note).

        Args:
            mesh: The permanent elements' triangles, world metres.
            face_owner: (F,) each triangle's element index.
            element_classes: Each element's IFC class.
            config: The area and class rules.

        Returns:
            The faces: owner, unit normal, offset (m) and area (m^2) each.
        """
        normals, areas = np.asarray(mesh.face_normals), np.asarray(mesh.area_faces)
        offsets = np.einsum("ni,ni->n", normals, np.asarray(mesh.triangles_center))
        step = np.deg2rad(config.angle_step_deg)
        key = np.concatenate([face_owner[:, None], np.round(normals / step),
                              np.round(offsets / config.offset_step)[:, None]], axis=1).astype(np.int64)
        groups, inverse = np.unique(key, axis=0, return_inverse=True)
        inverse = inverse.reshape(-1)
        area = np.bincount(inverse, weights=areas)
        element_area = np.bincount(face_owner, weights=areas, minlength=len(element_classes))
        summed = np.stack([np.bincount(inverse, weights=normals[:, i] * areas) for i in range(3)], axis=1)
        normal = summed / np.linalg.norm(summed, axis=1, keepdims=True)
        offset = np.bincount(inverse, weights=offsets * areas) / area
        owner = groups[:, 0]
        flat = np.array([c not in config.non_planar_classes for c in element_classes], dtype=bool)
        keep = flat[owner] & (area >= config.min_area) & (area >= config.min_share * element_area[owner])
        return cls(owner[keep], normal[keep], offset[keep], area[keep])

    def __len__(self) -> int:
        return len(self.owner)

    def label(self, points: np.ndarray, normals: np.ndarray, owner: np.ndarray, on_face: float) -> np.ndarray:
        """The face each surface sample lies on: its element's face whose plane lies within ``on_face`` and whose
        normal agrees within 25 degrees (either sign).

        Args:
            points: (N, 3) samples, world metres.
            normals: (N, 3) their unit normals.
            owner: (N,) each sample's element index.
            on_face: How far from a face's plane a sample may lie, m.

        Returns:
            (N,) face index per sample, -1 for none (a stair, a curved wall, a small face).
        """
        out = np.full(len(points), -1)
        for face in range(len(self)):
            mine = owner == self.owner[face]
            if not mine.any():
                continue
            near = np.abs(points[mine] @ self.normal[face] - self.offset[face]) <= on_face
            agree = np.abs(normals[mine] @ self.normal[face]) >= np.cos(np.deg2rad(25.0))
            index = np.flatnonzero(mine)[near & agree]
            out[index] = face
        return out
