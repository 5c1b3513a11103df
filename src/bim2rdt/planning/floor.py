"""Which storey the robot walks, at what height its floor is, and where there is floor at all.

The floor's height comes from the BIM, never a constant: the top of the storey's slab nearest the storey's
elevation. Revit exports often carry no floor slabs at all (Office_A has only two stair landings): then the
storey's spaces stand in, their bottoms being the finished floor. A storey with neither has no floor to stand
on, which is an error. Where there is no floor (outside the building on an upper storey, a stair well) the robot
must not go: ``floor_mask`` marks the floor; the grid blocks the rest.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from bim2rdt.bim import BimModel, BimStorey
from bim2rdt.planning.errors import PlanningError
from bim2rdt.planning.frame import GridFrame
from bim2rdt.planning.raster import fill_triangles

SLAB_LEVEL_TOLERANCE = 0.5
"""A slab of the storey counts as its floor when its top is within this of the storey's elevation, m (stair
landings and roof slabs assigned to the storey are farther)."""
SURFACE_TOLERANCE = 0.1
"""Floor faces within this of the floor height belong to the walking surface, m (finish layers, thresholds)."""
SPACE_WALL_BRIDGE = 0.35
"""Spaces stop at wall faces; a floor taken from spaces is grown by this, m, so doorways through walls up to
0.7 m thick join the rooms (the walls themselves stay obstacles)."""


@dataclass(frozen=True)
class Floor:
    """The storey's walking surface: world height ``z`` (m), where it came from (``slab`` or ``spaces``) and
    the GlobalIds of the elements that make it."""

    storey: BimStorey
    z: float
    source: str
    element_ids: tuple[str, ...]


def find_floor(model: BimModel, storey: str | BimStorey | None = None) -> Floor:
    """The floor of ``storey`` (a name, GlobalId or BimStorey); None picks the storey with a floor whose
    elevation is nearest 0 (the ground floor). PlanningError for an unknown storey or one without a floor."""
    if model.meshes is None:
        raise PlanningError(f"{model.path.name}: loaded without geometry; planning needs load_ifc(..., geometry=True)")
    if storey is not None:
        return _floor_of(model, _storey(model, storey))
    floors = [_floor_or_none(model, s) for s in model.storeys]
    floors = [f for f in floors if f is not None]
    if not floors:
        raise PlanningError(f"{model.path.name}: no storey has a slab (or a space) to take its floor from")
    return min(floors, key=lambda f: abs(f.storey.elevation or 0.0))


def floor_mask(model: BimModel, floor: Floor, frame: GridFrame) -> np.ndarray:
    """Whole-grid bool: cells over the floor (slab tops or space bottoms at the floor's height)."""
    faces = [_level_faces(model, gid, floor.z) for gid in floor.element_ids]
    if floor.source == "slab":
        faces += [_level_faces(model, el.global_id, floor.z) for el in model.elements
                  if _is_slab(el.ifc_class) and el.global_id not in floor.element_ids and model.has_mesh(el.global_id)]
    mask = fill_triangles(np.concatenate(faces) if faces else np.zeros((0, 3, 2)), frame)
    if floor.source == "spaces":
        radius = int(np.ceil(SPACE_WALL_BRIDGE / frame.resolution))
        disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1, 2 * radius + 1))
        mask = cv2.dilate(mask.astype(np.uint8), disc).astype(bool)
    return mask


def floor_extent(model: BimModel, floor: Floor) -> tuple[np.ndarray, np.ndarray]:
    """(low_xy, high_xy) world metres of the elements making the floor."""
    vertices = np.concatenate([model.mesh(gid)[0] for gid in floor.element_ids])
    return vertices[:, :2].min(axis=0), vertices[:, :2].max(axis=0)


def _storey(model: BimModel, wanted: str | BimStorey) -> BimStorey:
    key = wanted.global_id if isinstance(wanted, BimStorey) else str(wanted)
    for storey in model.storeys:
        if key in (storey.global_id, storey.name):
            return storey
    names = ", ".join(repr(s.name) for s in model.storeys) or "none"
    raise PlanningError(f"{model.path.name}: no storey {key!r} (storeys: {names})")


def _floor_of(model: BimModel, storey: BimStorey) -> Floor:
    floor = _floor_or_none(model, storey)
    if floor is None:
        raise PlanningError(f"{model.path.name}: storey {storey.name!r} has no slab (and no space) at its "
                            f"elevation to take the floor from")
    return floor


def _floor_or_none(model: BimModel, storey: BimStorey) -> Floor | None:
    members = [el for el in model.elements if el.storey == storey.name and model.has_mesh(el.global_id)]
    slabs = {el.global_id: float(model.mesh(el.global_id)[0][:, 2].max()) for el in members if _is_slab(el.ifc_class)}
    if storey.elevation is not None:
        slabs = {gid: top for gid, top in slabs.items() if abs(top - storey.elevation) <= SLAB_LEVEL_TOLERANCE}
    if slabs:
        reference = storey.elevation if storey.elevation is not None else min(slabs.values())
        z = min(slabs.values(), key=lambda top: abs(top - reference))
        return Floor(storey, z, "slab", tuple(g for g, top in slabs.items() if abs(top - z) <= SURFACE_TOLERANCE))
    spaces = {el.global_id: float(model.mesh(el.global_id)[0][:, 2].min()) for el in members
              if el.ifc_class == "IfcSpace"}
    if not spaces:
        return None
    reference = storey.elevation if storey.elevation is not None else min(spaces.values())
    z = min(spaces.values(), key=lambda bottom: abs(bottom - reference))
    return Floor(storey, z, "spaces", tuple(g for g, bottom in spaces.items() if abs(bottom - z) <= SURFACE_TOLERANCE))


def _level_faces(model: BimModel, global_id: str, z: float) -> np.ndarray:
    """Plan triangles (M, 3, 2) of an element's faces lying flat at height ``z`` (a slab's top, a space's
    bottom; the other side is a slab's depth or a room's height away). Orientation is not trusted: some
    exporters wind faces inward."""
    vertices, faces = model.mesh(global_id)
    triangles = vertices[faces]
    normal = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    flat = np.abs(normal[:, 2]) > 0.9 * np.linalg.norm(normal, axis=1)
    level = np.all(np.abs(triangles[..., 2] - z) <= SURFACE_TOLERANCE, axis=1)
    return triangles[flat & level][..., :2]


def _is_slab(ifc_class: str) -> bool:
    return ifc_class.startswith("IfcSlab")
