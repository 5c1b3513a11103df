"""Reading the semantic content of an IFC file: elements, storeys, zones (no geometry here).

Units: every length leaves this module in metres (``unit_scale`` = metres per project length unit).
Property sets only: quantity sets (IfcElementQuantity) are derived numbers, not the designer's data.
"""

from __future__ import annotations

from typing import Any

import ifcopenshell
import ifcopenshell.util.element
import ifcopenshell.util.placement
import numpy as np

from bim2rdt.bim.family import resolve_family
from bim2rdt.bim.records import BimElement, BimStorey, BimZone, Psets

ZONE_PSET = "BIM2RDT_Zone"
"""The property set that tags a space or zone: ``OffLimits`` (bool) and ``ZoneKind`` (label)."""

SKIPPED_CLASSES = ("IfcFeatureElement",)
"""Openings and projections are voids/features of other elements, not objects on site."""


def read_elements(ifc: ifcopenshell.file, unit_scale: float) -> list[BimElement]:
    """Every physical element and every space, with family, storey, psets and placement (metres)."""
    products = [el for el in ifc.by_type("IfcElement") if not el.is_a(SKIPPED_CLASSES[0])]
    products += list(ifc.by_type("IfcSpace"))
    return [_element(el, unit_scale) for el in products]


def read_storeys(ifc: ifcopenshell.file, unit_scale: float) -> list[BimStorey]:
    """Storeys sorted by elevation (metres); storeys without an Elevation sort last."""
    storeys = [BimStorey(s.GlobalId, s.Name, s.Elevation * unit_scale if s.Elevation is not None else None)
               for s in ifc.by_type("IfcBuildingStorey")]
    return sorted(storeys, key=lambda s: (s.elevation is None, s.elevation or 0.0))


def read_zones(ifc: ifcopenshell.file) -> list[BimZone]:
    """Spaces and zones (IfcZone groups of spaces) with their off-limits tag."""
    zones = []
    for space in ifc.by_type("IfcSpace"):
        zones.append(_zone(space, storey_name(space), ()))
    for zone in ifc.by_type("IfcZone"):
        members = tuple(obj.GlobalId for rel in zone.IsGroupedBy or [] for obj in rel.RelatedObjects)
        zones.append(_zone(zone, None, members))
    return zones


def read_psets(entity: ifcopenshell.entity_instance) -> Psets:
    """Property sets (inherited from the type too) as {pset: {property: value}}, ifcopenshell ids dropped."""
    psets = ifcopenshell.util.element.get_psets(entity, psets_only=True)
    return {name: {key: _plain(value) for key, value in props.items() if key != "id"}
            for name, props in psets.items()}


def storey_name(product: ifcopenshell.entity_instance) -> str | None:
    """The storey an element stands in, directly, through a space, or through the aggregate it belongs to."""
    current = product
    for _ in range(8):
        storey = ifcopenshell.util.element.get_container(current, ifc_class="IfcBuildingStorey")
        if storey is not None:
            return storey.Name
        parent = ifcopenshell.util.element.get_aggregate(current)
        if parent is None:
            return None
        if parent.is_a("IfcBuildingStorey"):
            return parent.Name
        current = parent
    return None


def placement_matrix(product: ifcopenshell.entity_instance, unit_scale: float) -> np.ndarray:
    """ObjectPlacement as a 4x4 world matrix in metres (ifcopenshell returns project units)."""
    if product.ObjectPlacement is None:
        return np.eye(4)
    matrix = np.array(ifcopenshell.util.placement.get_local_placement(product.ObjectPlacement), dtype=float)
    matrix[:3, 3] *= unit_scale
    return matrix


def _element(el: ifcopenshell.entity_instance, unit_scale: float) -> BimElement:
    element_type = ifcopenshell.util.element.get_type(el)
    family = resolve_family(getattr(element_type, "Name", None), getattr(el, "ObjectType", None), el.Name)
    return BimElement(global_id=el.GlobalId, ifc_class=el.is_a(), name=el.Name, family=family,
                      storey=storey_name(el), placement=placement_matrix(el, unit_scale), psets=read_psets(el))


def _zone(entity: ifcopenshell.entity_instance, storey: str | None, members: tuple[str, ...]) -> BimZone:
    tag = read_psets(entity).get(ZONE_PSET, {})
    off_limits = tag.get("OffLimits")
    return BimZone(entity.GlobalId, entity.is_a(), entity.Name, storey,
                   bool(off_limits) if off_limits is not None else None, tag.get("ZoneKind"), members)


def _plain(value: Any) -> Any:
    """Pset values as JSON-friendly Python values (tuples from list/enumerated properties become lists)."""
    if isinstance(value, tuple | list):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, ifcopenshell.entity_instance):
        return str(value)
    return value
