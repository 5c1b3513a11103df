"""Which BIM elements are obstacles in the robot's height band, and the door policy.

Everything with a body that reaches into the band is an obstacle (walls, columns, furniture, equipment, stairs,
railings, a roof that slopes down into an attic, the site's planned objects), whatever storey it is filed under:
geometry decides, not the spatial tree. Spaces and virtual elements are not physical; openings are already
cut out of their walls by the geometry kernel, so a doorway is a gap. Doors are open or closed by a policy: an
open door leaves its opening free, a closed one fills it with its leaf.
"""

from __future__ import annotations

from collections.abc import Collection

from bim2rdt.bim import BimElement, BimModel
from bim2rdt.planning.errors import PlanningError
from bim2rdt.planning.frame import GridFrame
from bim2rdt.planning.raster import Footprint, mesh_cells

NOT_PHYSICAL = ("IfcSpace", "IfcVirtualElement", "IfcOpeningElement", "IfcOpeningStandardCase", "IfcAnnotation")
WALL_CLASSES = ("IfcWall", "IfcCurtainWall")
"""IfcWall covers IfcWallStandardCase and IfcWallElementedCase (class names are matched by prefix)."""

DoorPolicy = str | Collection[str]
"""``"open"`` (every door passable), ``"closed"`` (none), or the GlobalIds/names of the doors that are closed."""


def require_walls(model: BimModel) -> None:
    """A BIM with no walls is no building to plan in (a furniture library, a site model): say so."""
    if not any(el.ifc_class.startswith(WALL_CLASSES) for el in model.elements):
        raise PlanningError(f"{model.path.name}: the BIM has no walls (IfcWall/IfcCurtainWall) to plan around")


def check_door_policy(doors: DoorPolicy) -> None:
    if isinstance(doors, str) and doors not in ("open", "closed"):
        raise PlanningError(f"door policy {doors!r}: use 'open', 'closed' or a list of closed doors' GlobalIds")


def door_is_closed(element: BimElement, doors: DoorPolicy) -> bool:
    if isinstance(doors, str):
        return doors == "closed"
    return element.global_id in doors or (element.name is not None and element.name in doors)


def element_footprints(model: BimModel, z_band: tuple[float, float], frame: GridFrame,
                       doors: DoorPolicy) -> tuple[list[Footprint], list[str]]:
    """Footprints of every element reaching into ``z_band`` (world heights), and the names of the open doors
    left out."""
    footprints, open_doors = [], []
    for element in model.elements:
        if element.ifc_class in NOT_PHYSICAL or not model.has_mesh(element.global_id):
            continue
        is_door = element.ifc_class.startswith("IfcDoor")
        cells = mesh_cells(*model.mesh(element.global_id), z_band, frame)
        if cells is None:
            continue
        if is_door and not door_is_closed(element, doors):
            open_doors.append(element.name or element.global_id)
            continue
        footprints.append(Footprint(element.name or element.global_id, "door" if is_door else "element", *cells,
                                    global_id=element.global_id, ifc_class=element.ifc_class))
    return footprints, open_doors
