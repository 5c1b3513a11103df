"""Site objects for any building: where the simulator puts them on a storey's slab, and the IFC copy that holds
them, so the demo's loop runs on a real model (``bim2rdt demo --ifc FILE``).

Placement works on the planner's map of the storey (``planning.OccupancyGrid``): spots must be on the floor,
free with room to spare (the object's own radius plus ``CLEARANCE``, so no object closes a doorway or a
corridor), and reachable from the robot's dock. The dock is the roomiest spot of the largest room; then each
of the storey's rooms (its spaces; without spaces, the free area is treated as one) gets one object, rooms far from
the dock first, so the robot walks room to room through the doors. The drum nobody planned and the workers go
to further free spots, well away from the objects (or nowhere, where the floor is too small). Everything is
seeded.

The copy adds each object as an ``IfcBuildingElementProxy`` on the storey (type named after its family, a body
mesh, a ``BIM2RDT_SiteObject`` pset), with GlobalIds derived from the file's own digest and the header time
fixed, so the same input gives the same bytes (and the tessellation cache stays warm). IFC2X3 files get
faceted B-rep bodies, IFC4 ones polygonal face sets.
"""

from __future__ import annotations

import uuid
from dataclasses import dataclass, field
from pathlib import Path

import ifcopenshell
import ifcopenshell.api.geometry
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.api.type
import ifcopenshell.guid
import ifcopenshell.util.representation
import numpy as np
from scipy import ndimage

from bim2rdt.bim import BimModel
from bim2rdt.bim.atomic import atomic_write_ifc
from bim2rdt.bim.ifc_values import add_typed_pset
from bim2rdt.bim.spatial import storey_name
from bim2rdt.planning import OccupancyGrid, reachable
from bim2rdt.planning.raster import mesh_cells
from bim2rdt.sim.meshes import mesh_for_family
from bim2rdt.sim.site import SiteObject, yaw_pose

FAMILIES = ("Steel_Drum_55gal", "Wooden_Crate_1200x800x600", "Traffic_Cone_Orange_70cm", "Pallet_Wood_EUR",
            "Survey_Tripod_Aluminium", "Scaffold_Frame_1000x2000", "Traffic_Cone_Orange_70cm")
"""Families placed, one per room, in this order."""
CLEARANCE = 0.6
"""Free space kept around an object beyond its own radius, m: a robot (0.7 m across) passes beside it."""
UNPLANNED_APART = 3.5
"""The unplanned drum stands at least this far from the planned objects and the dock, m: not on the spot the
robot will want to look at them from."""
WORKER_APART = 4.0
"""A worker stands at least this far from the objects and the dock, m, or (in a small building) nowhere on the
robot's floor: their idle keep-out circle must not sit on the robot's stations all day."""
_NAMESPACE = uuid.UUID("0f6a3c52-7d1e-4b7a-9c0e-5d2b8e4f6a11")
FIXED_TIME = 1767225600
"""2026-01-01T00:00:00Z: the time stamp of the owner histories the copy adds."""


@dataclass(frozen=True)
class Layout:
    """Where things go on the storey: planned site objects, the robot's dock, the unplanned drum, the workers."""

    storey: str
    floor_z: float
    objects: tuple[SiteObject, ...]
    dock_xy: tuple[float, float]
    unplanned_xy: tuple[float, float] | None
    worker_spots: dict[str, tuple[float, float]] = field(default_factory=dict)


def furnish(model: BimModel, grid: OccupancyGrid, workers: int = 1, seed: int = 0,
            objects: int = len(FAMILIES)) -> Layout:
    """Spots for up to ``objects`` site objects (one per room, far rooms first), the dock, an unplanned drum and
    ``workers`` on ``grid``'s storey."""
    wanted = max(1, min(objects, len(FAMILIES)))
    rng = np.random.default_rng(seed)
    clearance = ndimage.distance_transform_edt(~grid.occupied) * grid.resolution
    spaces = _rooms(model, grid, ~grid.blocked)
    largest = max(spaces, key=lambda room: np.count_nonzero(room & ~grid.blocked))
    dock_cell = np.unravel_index(np.argmax(np.where(largest & ~grid.blocked, clearance, -1.0)), clearance.shape)
    dock = grid.frame.centres(*dock_cell)
    free = reachable(grid, dock)
    rooms = [room for room in spaces if (room & free).any()]
    taken: list[np.ndarray] = [dock]
    placed = []
    for room in sorted(rooms, key=lambda mask: -_distance(grid, mask, dock)):
        family = FAMILIES[len(placed) % len(FAMILIES)]
        spot = _spot(grid, clearance, room & free, _radius(family) + CLEARANCE, taken, rng)
        if spot is not None:
            placed.append(SiteObject(family, float(spot[0]), float(spot[1]), float(rng.uniform(-60.0, 60.0))))
            taken.append(spot)
        if len(placed) == wanted:
            break
    unplanned = _spot(grid, clearance, free, _radius("Steel_Drum_55gal") + CLEARANCE, taken, rng,
                      apart=UNPLANNED_APART)
    taken += [] if unplanned is None else [unplanned]
    spots = {}
    for k in range(workers):
        spot = _spot(grid, clearance, free, 1.0, taken, rng, farthest=True, apart=WORKER_APART)
        if spot is not None:
            spots[f"w{k + 1}"] = (float(spot[0]), float(spot[1]))
            taken.append(spot)
    return Layout(grid.storey, grid.floor_z, tuple(placed), (float(dock[0]), float(dock[1])),
                  None if unplanned is None else (float(unplanned[0]), float(unplanned[1])), spots)


def write_furnished(model: BimModel, layout: Layout, path: Path) -> Path:
    """A copy of ``model``'s file with the layout's objects as proxies on its storey, written atomically."""
    ifc = ifcopenshell.open(str(model.path))
    first_new = max(entity.id() for entity in ifc) + 1
    storey = next(s for s in ifc.by_type("IfcBuildingStorey") if storey_name(s) == layout.storey)
    context = _body_context(ifc)
    for item in layout.objects:
        _add_object(ifc, storey, context, item, layout.floor_z, model.unit_scale)
    _stabilise(ifc, first_new, model.digest)
    return atomic_write_ifc(ifc, Path(path))


def _rooms(model: BimModel, grid: OccupancyGrid, free: np.ndarray) -> list[np.ndarray]:
    """Cell masks of the storey's spaces that hold free, reachable floor; the free area itself if none do."""
    rooms = []
    for zone in model.zones:
        if zone.ifc_class != "IfcSpace" or zone.storey != grid.storey or not model.has_mesh(zone.global_id):
            continue
        cells = mesh_cells(*model.mesh(zone.global_id), grid.z_band, grid.frame)
        if cells is None:
            continue
        row0, col0, mask = cells
        room = np.zeros(grid.frame.shape, bool)
        room[row0:row0 + mask.shape[0], col0:col0 + mask.shape[1]] = mask
        if (room & free).any():
            rooms.append(room)
    return rooms or [free]


def _spot(grid: OccupancyGrid, clearance: np.ndarray, where: np.ndarray, room_needed: float, taken, rng,
          farthest: bool = False, apart: float = 2.5) -> np.ndarray | None:
    """A free cell centre in ``where`` with ``room_needed`` m of clearance, at least ``apart`` m from spots
    taken: seeded at random among them, or the farthest from all taken (``farthest``)."""
    rows, cols = np.nonzero(where & (clearance >= room_needed))
    if not len(rows):
        return None
    centres = grid.frame.centres(rows, cols)
    gaps = np.min(np.linalg.norm(centres[:, None, :] - np.asarray(taken)[None], axis=2), axis=1)
    if farthest:
        best = int(np.argmax(gaps))
        return centres[best] if gaps[best] >= apart else None
    far_enough = np.flatnonzero(gaps >= apart)
    return centres[int(rng.choice(far_enough))] if len(far_enough) else None


def _distance(grid: OccupancyGrid, room: np.ndarray, xy: np.ndarray) -> float:
    rows, cols = np.nonzero(room)
    return float(np.linalg.norm(grid.frame.centres(rows, cols).mean(axis=0) - xy))


def _radius(family: str) -> float:
    return float(np.max(np.linalg.norm(mesh_for_family(family).vertices[:, :2], axis=1)))


def _body_context(ifc: ifcopenshell.file):
    return (ifcopenshell.util.representation.get_context(ifc, "Model", "Body", "MODEL_VIEW")
            or ifcopenshell.util.representation.get_context(ifc, "Model", "Body")
            or ifcopenshell.util.representation.get_context(ifc, "Model"))


def _add_object(ifc: ifcopenshell.file, storey, context, item: SiteObject, floor_z: float, unit_scale: float) -> None:
    proxy = ifcopenshell.api.root.create_entity(ifc, "IfcBuildingElementProxy", name=item.family)
    proxy.ObjectType = item.family
    ifcopenshell.api.spatial.assign_container(ifc, products=[proxy], relating_structure=storey)
    kind = next((t for t in ifc.by_type("IfcBuildingElementProxyType") if t.Name == item.family), None)
    kind = kind or ifcopenshell.api.root.create_entity(ifc, "IfcBuildingElementProxyType", name=item.family)
    ifcopenshell.api.type.assign_type(ifc, related_objects=[proxy], relating_type=kind,
                                      should_map_representations=False)
    mesh = mesh_for_family(item.family)
    body = ifcopenshell.api.geometry.add_mesh_representation(  # metres in; the api divides by the file's scale
        ifc, context=context, vertices=[mesh.vertices.tolist()], faces=[mesh.faces.tolist()], unit_scale=unit_scale)
    ifcopenshell.api.geometry.assign_representation(ifc, product=proxy, representation=body)
    ifcopenshell.api.geometry.edit_object_placement(ifc, product=proxy, is_si=True,
                                                    matrix=yaw_pose(item.x, item.y, floor_z, item.yaw_deg))
    add_typed_pset(ifc, proxy, "BIM2RDT_SiteObject", {"Movable": True, "Layout": "demo --ifc"})


def _stabilise(ifc: ifcopenshell.file, first_new: int, digest: str) -> None:
    """The same input, the same bytes: GlobalIds of what was added derived from the source's digest, members of
    the relations it joined in id order (the api fills them from sets), the owner histories the api stamped with
    the clock set to a fixed time, and a fixed header time stamp."""
    added = [entity for entity in ifc if entity.id() >= first_new]
    for index, entity in enumerate(sorted(added, key=lambda e: e.id())):
        if entity.is_a("IfcRoot"):
            entity.GlobalId = _guid(digest, f"{entity.is_a()}:{index}")
        if entity.is_a("IfcOwnerHistory"):
            entity.CreationDate = FIXED_TIME
            entity.LastModifiedDate = FIXED_TIME if entity.LastModifiedDate is not None else None
    for relation in ifc.by_type("IfcRelationship"):
        for attribute in ("RelatedElements", "RelatedObjects"):
            members = getattr(relation, attribute, None)
            if isinstance(members, tuple) and any(member.id() >= first_new for member in members):
                setattr(relation, attribute, sorted(members, key=lambda entity: entity.id()))
    ifc.header.file_name.time_stamp = "2026-01-01T00:00:00"


def _guid(digest: str, key: str) -> str:
    return ifcopenshell.guid.compress(uuid.uuid5(_NAMESPACE, f"{digest}:{key}").hex)
