"""The building's permanent elements: what a BIM explains in a site camera's view before any site object.

Walls, slabs, columns, doors and the like do not wander about a site; temporary works, materials and equipment
(``IfcBuildingElementProxy``, furniture) do, and spaces are not physical. Scan-vs-BIM starts by explaining the
view with the permanent ones and looks for objects in what is left.
"""

from __future__ import annotations

from bim2rdt.bim import BimElement, BimModel

PERMANENT_CLASSES = frozenset({
    "IfcWall", "IfcWallStandardCase", "IfcWallElementedCase", "IfcCurtainWall", "IfcSlab", "IfcSlabStandardCase",
    "IfcSlabElementedCase", "IfcRoof", "IfcColumn", "IfcColumnStandardCase", "IfcBeam", "IfcBeamStandardCase",
    "IfcMember", "IfcPlate", "IfcDoor", "IfcDoorStandardCase", "IfcWindow", "IfcWindowStandardCase", "IfcStair",
    "IfcStairFlight", "IfcRamp", "IfcRampFlight", "IfcRailing", "IfcCovering", "IfcFooting", "IfcPile",
    "IfcChimney", "IfcShadingDevice", "IfcBuildingElementPart", "IfcFlowSegment", "IfcFlowFitting",
    "IfcDuctSegment", "IfcDuctFitting", "IfcPipeSegment", "IfcPipeFitting", "IfcCableCarrierSegment"})
"""IFC classes of elements that stay where the BIM puts them (IFC2X3 and IFC4 names)."""


NOT_OBJECTS = frozenset({"IfcSpace", "IfcOpeningElement", "IfcVirtualElement", "IfcAnnotation", "IfcGrid",
                         "IfcSite", "IfcBuilding", "IfcBuildingStorey", "IfcSpatialZone", "IfcZone"})
"""Classes that are neither structure nor objects a camera could see (spaces, voids, annotations)."""


def permanent_elements(model: BimModel) -> list[BimElement]:
    """The model's permanent elements (:data:`PERMANENT_CLASSES`) that have a tessellated body.

    Args:
        model: The BIM.

    Returns:
        Those elements, in the model's order.
    """
    return [el for el in model.elements if el.ifc_class in PERMANENT_CLASSES and model.has_mesh(el.global_id)]


def movable_elements(model: BimModel) -> list[BimElement]:
    """The model's site objects: elements with a body and a family that are neither permanent nor spaces
    (temporary works, materials, equipment, furniture): what a detector looks for.

    Args:
        model: The BIM, loaded with geometry.

    Returns:
        Its site objects.
    """
    return [el for el in model.elements
            if el.ifc_class not in PERMANENT_CLASSES and el.ifc_class not in NOT_OBJECTS and el.family
            and model.has_mesh(el.global_id)]
