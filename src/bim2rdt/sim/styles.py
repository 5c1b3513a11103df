"""Surface colours from an IFC file's own presentation styles, for the simulated camera.

Authoring tools store a colour per element in one of three places, and the first found wins, as in viewers:
a style on the body's representation items (``IfcStyledItem`` -> ``IfcSurfaceStyle`` -> shading colour; IFC2X3
wraps it in ``IfcPresentationStyleAssignment``; mapped items and boolean results are followed to their
operands), else a style on the element's material (``IfcMaterialDefinitionRepresentation``; the first layer
or constituent of a set: the face you see). Elements with neither get no entry, and the caller picks a colour
for their class.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path

import ifcopenshell
import ifcopenshell.util.element

from bim2rdt.sim.scene import Colour

_BODY = ("Body", "Facetation", None)


def surface_colours(path: str | Path, global_ids: Iterable[str]) -> dict[str, Colour]:
    """{GlobalId: (r, g, b) in 0-1} for the elements of the IFC file at ``path`` that carry a surface colour."""
    ifc = ifcopenshell.open(str(path))
    colours = {}
    for global_id in global_ids:
        try:
            product = ifc.by_guid(global_id)
        except RuntimeError:  # ifcopenshell's way of saying 'no such GlobalId'
            continue
        colour = next(_representation_colours(product), None) or _material_colour(product)
        if colour is not None:
            colours[global_id] = colour
    return colours


def _representation_colours(product) -> Iterator[Colour]:
    shape = getattr(product, "Representation", None)
    for representation in (shape.Representations if shape else ()):
        if representation.RepresentationIdentifier in _BODY:
            for item in representation.Items:
                yield from _item_colours(item)


def _item_colours(item) -> Iterator[Colour]:
    for styled in getattr(item, "StyledByItem", None) or ():
        for style in styled.Styles:
            yield from _style_colours(style)
    if item.is_a("IfcMappedItem"):
        for inner in item.MappingSource.MappedRepresentation.Items:
            yield from _item_colours(inner)
    elif item.is_a("IfcBooleanResult"):
        yield from _item_colours(item.FirstOperand)


def _style_colours(style) -> Iterator[Colour]:
    if style.is_a("IfcPresentationStyleAssignment"):
        for inner in style.Styles:
            yield from _style_colours(inner)
    elif style.is_a("IfcSurfaceStyle"):
        for element in style.Styles:
            if element.is_a("IfcSurfaceStyleShading") and element.SurfaceColour is not None:
                rgb = element.SurfaceColour
                yield (float(rgb.Red), float(rgb.Green), float(rgb.Blue))


def _material_colour(product) -> Colour | None:
    material = ifcopenshell.util.element.get_material(product, should_skip_usage=True)
    for candidate in _materials(material):
        for definition in getattr(candidate, "HasRepresentation", None) or ():
            for representation in definition.Representations:
                for item in representation.Items:
                    colour = next(_item_colours(item), None)
                    if colour is not None:
                        return colour
    return None


def _materials(material) -> list:
    """The visible material first: a layer set's first layer, a list's or constituent set's first member."""
    if material is None:
        return []
    if material.is_a("IfcMaterialLayerSet"):
        return [layer.Material for layer in material.MaterialLayers if layer.Material is not None]
    if material.is_a("IfcMaterialList"):
        return list(material.Materials)
    if material.is_a("IfcMaterialConstituentSet"):
        return [c.Material for c in material.MaterialConstituents or () if c.Material is not None]
    if material.is_a("IfcMaterialProfileSet"):
        return [p.Material for p in material.MaterialProfiles if p.Material is not None]
    return [material] if material.is_a("IfcMaterial") else []
