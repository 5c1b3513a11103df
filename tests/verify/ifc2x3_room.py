"""A small IFC2X3 model written here (the site builder writes IFC4): a 6 x 4 m room, four walls 2.8 m high and a
slab, each an extruded rectangle; enough for verify to localize on, and a schema the twin cannot be written
back into."""

from __future__ import annotations

from pathlib import Path

import ifcopenshell
import ifcopenshell.guid

WALLS = ((3.0, -0.1, 6.2, 0.2), (3.0, 4.1, 6.2, 0.2), (-0.1, 2.0, 0.2, 4.0), (6.1, 2.0, 0.2, 4.0))
"""Each wall's centre x, y and its size x, y (metres)."""


def write_room_ifc2x3(path: Path) -> Path:
    """Write the room; returns ``path``."""
    f = ifcopenshell.file(schema="IFC2X3")
    person = f.createIfcPerson(None, "Doe", "Jo")
    organisation = f.createIfcOrganization(None, "bim2rdt tests")
    owner = f.createIfcOwnerHistory(f.createIfcPersonAndOrganization(person, organisation),
                                    f.createIfcApplication(organisation, "0", "tests", "tests"), None, "ADDED",
                                    None, None, None, 1700000000)
    origin = f.createIfcAxis2Placement3D(f.createIfcCartesianPoint((0.0, 0.0, 0.0)), None, None)
    context = f.createIfcGeometricRepresentationContext(None, "Model", 3, 1e-5, origin, None)
    units = f.createIfcUnitAssignment([f.createIfcSIUnit(None, "LENGTHUNIT", None, "METRE")])
    project = f.createIfcProject(ifcopenshell.guid.new(), owner, "Room", None, None, None, None, [context], units)
    site_place = f.createIfcLocalPlacement(None, origin)
    site = f.createIfcSite(ifcopenshell.guid.new(), owner, "Site", None, None, site_place, None, None, "ELEMENT",
                           None, None, None, None, None)
    building_place = f.createIfcLocalPlacement(site_place, origin)
    building = f.createIfcBuilding(ifcopenshell.guid.new(), owner, "Building", None, None, building_place, None,
                                   None, "ELEMENT", None, None, None)
    storey_place = f.createIfcLocalPlacement(building_place, origin)
    storey = f.createIfcBuildingStorey(ifcopenshell.guid.new(), owner, "Ground", None, None, storey_place, None,
                                       None, "ELEMENT", 0.0)
    for whole, parts in ((project, [site]), (site, [building]), (building, [storey])):
        f.createIfcRelAggregates(ifcopenshell.guid.new(), owner, None, None, whole, parts)
    elements = [_box(f, owner, context, storey_place, "IfcWallStandardCase", f"Wall {k}", (x, y, 0.0), (sx, sy, 2.8))
                for k, (x, y, sx, sy) in enumerate(WALLS)]
    elements.append(_box(f, owner, context, storey_place, "IfcSlab", "Slab", (3.0, 2.0, -0.2), (6.4, 4.4, 0.2)))
    f.createIfcRelContainedInSpatialStructure(ifcopenshell.guid.new(), owner, None, None, elements, storey)
    f.write(str(path))
    return Path(path)


def _box(f, owner, context, parent, ifc_class, name, corner_xyz, size_xyz):
    """An element whose body is a box: centred on x, y, from z up by its height."""
    x, y, z = corner_xyz
    sx, sy, sz = size_xyz
    placement = f.createIfcLocalPlacement(parent, f.createIfcAxis2Placement3D(
        f.createIfcCartesianPoint((float(x), float(y), float(z))), None, None))
    profile = f.createIfcRectangleProfileDef("AREA", None, f.createIfcAxis2Placement2D(
        f.createIfcCartesianPoint((0.0, 0.0)), None), float(sx), float(sy))
    solid = f.createIfcExtrudedAreaSolid(profile, f.createIfcAxis2Placement3D(
        f.createIfcCartesianPoint((0.0, 0.0, 0.0)), None, None), f.createIfcDirection((0.0, 0.0, 1.0)), float(sz))
    shape = f.createIfcProductDefinitionShape(None, None, [f.createIfcShapeRepresentation(
        context, "Body", "SweptSolid", [solid])])
    return f.create_entity(ifc_class, ifcopenshell.guid.new(), owner, name, None, None, placement, shape, None)
