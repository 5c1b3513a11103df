"""Small IFC4 buildings for the planning tests, built with ifcopenshell's api (lengths in metres).

``two_rooms``: a 10 x 6 m storey (slab top at the storey's elevation), four exterior walls and a partition at
x = 5 with a 1.2 m doorway (an opening, optionally filled by a door), one room west, one east.
"""

from __future__ import annotations

from pathlib import Path

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.context
import ifcopenshell.api.feature
import ifcopenshell.api.geometry
import ifcopenshell.api.project
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.api.unit

from bim2rdt.sim.site import yaw_pose

LENGTH, WIDTH, HEIGHT, THICK = 10.0, 6.0, 3.0, 0.2
DOOR_Y = (2.4, 3.6)


class _Builder:
    def __init__(self) -> None:
        self.ifc = ifcopenshell.api.project.create_file(version="IFC4")
        project = ifcopenshell.api.root.create_entity(self.ifc, "IfcProject", name="test")
        ifcopenshell.api.unit.assign_unit(self.ifc, length={"is_metric": True, "raw": "METERS"})
        model = ifcopenshell.api.context.add_context(self.ifc, context_type="Model")
        self.body = ifcopenshell.api.context.add_context(self.ifc, context_type="Model", context_identifier="Body",
                                                         target_view="MODEL_VIEW", parent=model)
        self.site = ifcopenshell.api.root.create_entity(self.ifc, "IfcSite", name="site")
        self.building = ifcopenshell.api.root.create_entity(self.ifc, "IfcBuilding", name="building")
        ifcopenshell.api.aggregate.assign_object(self.ifc, products=[self.site], relating_object=project)
        ifcopenshell.api.aggregate.assign_object(self.ifc, products=[self.building], relating_object=self.site)

    def storey(self, name: str, elevation: float):
        storey = ifcopenshell.api.root.create_entity(self.ifc, "IfcBuildingStorey", name=name)
        storey.Elevation = elevation
        ifcopenshell.api.aggregate.assign_object(self.ifc, products=[storey], relating_object=self.building)
        return storey

    def box(self, storey, ifc_class: str, name: str, size, at, yaw: float = 0.0, centred: bool = False):
        """An extruded box of ``size`` (x, y, z); ``at`` (x, y, z) is its corner (or its base centre)."""
        element = ifcopenshell.api.root.create_entity(self.ifc, ifc_class, name=name)
        if not ifc_class.startswith(("IfcOpening", "IfcSpace")):
            ifcopenshell.api.spatial.assign_container(self.ifc, products=[element], relating_structure=storey)
        elif ifc_class == "IfcSpace":
            ifcopenshell.api.aggregate.assign_object(self.ifc, products=[element], relating_object=storey)
        cx, cy = (0.0, 0.0) if centred else (size[0] / 2, size[1] / 2)
        profile = self.ifc.create_entity(
            "IfcRectangleProfileDef", ProfileType="AREA", XDim=size[0], YDim=size[1],
            Position=self.ifc.create_entity("IfcAxis2Placement2D",
                                            Location=self.ifc.create_entity("IfcCartesianPoint", (cx, cy))))
        solid = self.ifc.create_entity(
            "IfcExtrudedAreaSolid", SweptArea=profile,
            Position=self.ifc.create_entity("IfcAxis2Placement3D",
                                            Location=self.ifc.create_entity("IfcCartesianPoint", (0.0, 0.0, 0.0))),
            ExtrudedDirection=self.ifc.create_entity("IfcDirection", (0.0, 0.0, 1.0)), Depth=size[2])
        representation = self.ifc.create_entity("IfcShapeRepresentation", ContextOfItems=self.body,
                                                RepresentationIdentifier="Body", RepresentationType="SweptSolid",
                                                Items=[solid])
        ifcopenshell.api.geometry.assign_representation(self.ifc, product=element, representation=representation)
        ifcopenshell.api.geometry.edit_object_placement(self.ifc, product=element, matrix=yaw_pose(*at, yaw),
                                                        is_si=True)
        return element

    def two_rooms(self, storey, z: float, slab: bool, walls: bool, door: bool, space: bool) -> None:
        if slab:
            self.box(storey, "IfcSlab", "Slab", (LENGTH, WIDTH, 0.25), (0.0, 0.0, z - 0.25))
        if space:
            self.box(storey, "IfcSpace", "Room", (LENGTH - 2 * THICK, WIDTH - 2 * THICK, 2.5), (THICK, THICK, z))
        if not walls:
            return
        for name, size, at in (("Wall South", (LENGTH, THICK, HEIGHT), (0.0, 0.0, z)),
                               ("Wall North", (LENGTH, THICK, HEIGHT), (0.0, WIDTH - THICK, z)),
                               ("Wall West", (THICK, WIDTH, HEIGHT), (0.0, 0.0, z)),
                               ("Wall East", (THICK, WIDTH, HEIGHT), (LENGTH - THICK, 0.0, z))):
            self.box(storey, "IfcWall", name, size, at)
        partition = self.box(storey, "IfcWall", "Partition", (THICK, WIDTH, HEIGHT), (5.0 - THICK / 2, 0.0, z))
        opening = self.box(storey, "IfcOpeningElement", "Doorway", (THICK + 0.1, DOOR_Y[1] - DOOR_Y[0], 2.1),
                           (5.0 - THICK / 2 - 0.05, DOOR_Y[0], z))
        ifcopenshell.api.feature.add_feature(self.ifc, feature=opening, element=partition)
        if door:
            leaf = self.box(storey, "IfcDoor", "Door D1", (0.05, DOOR_Y[1] - DOOR_Y[0], 2.1),
                            (5.0 - 0.025, DOOR_Y[0], z))
            ifcopenshell.api.feature.add_filling(self.ifc, opening=opening, element=leaf)

    def save(self, path: Path) -> Path:
        self.ifc.write(str(path))
        return path


def two_rooms(path: Path, *, elevation: float = 0.0, slab: bool = True, walls: bool = True, door: bool = True,
              space: bool = False, upper: bool = False, objects=()) -> Path:
    """The two-room storey at ``elevation``; ``upper`` adds a second storey 3.2 m higher with the same plan.
    ``objects``: (ifc_class, name, size, at) boxes on the (first) storey."""
    builder = _Builder()
    storey = builder.storey("Level 0", elevation)
    builder.two_rooms(storey, elevation, slab, walls, door, space)
    if upper:
        builder.two_rooms(builder.storey("Level 1", elevation + 3.2), elevation + 3.2, True, walls, door, space)
    for ifc_class, name, size, at in objects:
        builder.box(storey, ifc_class, name, size, at, centred=True)
    return builder.save(path)
