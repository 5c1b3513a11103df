"""Which BIM elements are permanent structure: the robot's a-priori map for localization.

Walls, columns, slabs, stairs, ramps, beams and door frames stay where the model puts them (to construction
tolerance), so their surfaces can anchor the robot's pose. Site objects (``IfcBuildingElementProxy``:
materials, equipment, temporary works), furniture and spaces move or are not solid, and windows and curtain
walls are glazed (a depth camera sees through glass): they are not part of the map.
"""

from __future__ import annotations

from bim2rdt.bim.model import BimModel
from bim2rdt.bim.records import BimElement

PERMANENT_CLASSES: frozenset[str] = frozenset({
    "IfcWall", "IfcWallStandardCase", "IfcWallElementedCase",
    "IfcColumn", "IfcColumnStandardCase",
    "IfcSlab", "IfcSlabStandardCase", "IfcSlabElementedCase",
    "IfcStair", "IfcStairFlight", "IfcRamp", "IfcRampFlight",
    "IfcBeam", "IfcBeamStandardCase",
    "IfcDoor", "IfcDoorStandardCase",
})
"""IFC classes whose elements are permanent structure (IFC2X3's *StandardCase classes included)."""


def is_permanent(element: BimElement) -> bool:
    """Whether the element is permanent structure (see :data:`PERMANENT_CLASSES`)."""
    return element.ifc_class in PERMANENT_CLASSES


def permanent_elements(model: BimModel) -> list[BimElement]:
    """The model's permanent elements that have a tessellated body (no body, nothing to see)."""
    return [el for el in model.elements if is_permanent(el) and model.has_mesh(el.global_id)]
