"""Which BIM elements make the robot's map for localization: solid, opaque, permanent structure built early.

Walls, columns, slabs, stairs, ramps, beams and door frames stay where the model puts them (to construction
tolerance) and a depth camera sees their surfaces, so they can anchor the robot's pose. Not in the map: site
objects (``IfcBuildingElementProxy``: materials, equipment, temporary works) and furniture, which move; spaces,
which are not solid; windows, curtain walls and plates, which are glazed more often than not (a depth camera
sees through glass); coverings, railings and other finishes, which arrive late in construction.
:data:`bim2rdt.perception.structure.PERMANENT_CLASSES` is wider on purpose: perception explains everything
the BIM fixes in place before it looks for site objects.
"""

from __future__ import annotations

from bim2rdt.bim.model import BimModel
from bim2rdt.bim.records import BimElement

MAP_CLASSES: frozenset[str] = frozenset({
    "IfcWall", "IfcWallStandardCase", "IfcWallElementedCase",
    "IfcColumn", "IfcColumnStandardCase",
    "IfcSlab", "IfcSlabStandardCase", "IfcSlabElementedCase",
    "IfcStair", "IfcStairFlight", "IfcRamp", "IfcRampFlight",
    "IfcBeam", "IfcBeamStandardCase",
    "IfcDoor", "IfcDoorStandardCase",
})
"""IFC classes whose elements make the localization map (IFC2X3's *StandardCase classes included)."""

NO_MAP = "no walls, columns, slabs, stairs or doors with a body: the robot has no map to localize on"
"""Why a model cannot be localized on, in the same words wherever it is said (``info --readiness``, its
``--require-map`` exit, and ``localize``'s refusal)."""


def in_map(element: BimElement) -> bool:
    """Whether the element belongs to the localization map (see :data:`MAP_CLASSES`)."""
    return element.ifc_class in MAP_CLASSES


def map_elements(model: BimModel) -> list[BimElement]:
    """The model's map elements that have a tessellated body (no body, nothing to see).

    Args:
        model: The BIM, loaded with geometry.

    Returns:
        Its permanent elements a sensor can localize on.
    """
    return [el for el in model.elements if in_map(el) and model.has_mesh(el.global_id)]
