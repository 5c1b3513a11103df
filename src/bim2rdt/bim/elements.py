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


def read_elements(ifc: ifcopenshell.file, unit_scale: float, psets: dict[int, Psets] | None = None) -> list[BimElement]:
    """Every physical element and every space, with family, storey, psets and placement (metres).
    ``psets`` is :func:`read_all_psets` of the file when the caller already has it."""
    products = [el for el in ifc.by_type("IfcElement") if not el.is_a(SKIPPED_CLASSES[0])]
    products += list(ifc.by_type("IfcSpace"))
    psets = read_all_psets(ifc) if psets is None else psets
    placements = PlacementResolver(unit_scale)
    return [_element(el, psets.get(el.id(), {}), placements(el)) for el in products]


def read_all_psets(ifc: ifcopenshell.file) -> dict[int, Psets]:
    """{entity id: psets} for the whole file in one pass over the relations: type psets first, occurrence psets
    override them (as ``get_psets`` does), each property set converted once however many objects share it."""
    converted: dict[int, dict[str, Any]] = {}

    def convert(definition: ifcopenshell.entity_instance) -> dict[str, Any]:
        if definition.id() not in converted:
            props = ifcopenshell.util.element.get_property_definition(definition)
            converted[definition.id()] = {k: _plain(v) for k, v in props.items() if k != "id"}
        return converted[definition.id()]

    found: dict[int, Psets] = {}
    for rel in ifc.by_type("IfcRelDefinesByType"):
        for definition in _property_sets(rel.RelatingType.HasPropertySets):
            for obj in rel.RelatedObjects:
                found.setdefault(obj.id(), {})[definition.Name] = dict(convert(definition))
    for rel in ifc.by_type("IfcRelDefinesByProperties"):
        for definition in _property_sets(rel.RelatingPropertyDefinition):
            for obj in rel.RelatedObjects:
                found.setdefault(obj.id(), {}).setdefault(definition.Name, {}).update(convert(definition))
    return found


class PlacementResolver:
    """ObjectPlacement -> 4x4 world matrix in metres, memoising shared parent placements (storeys, hosts)."""

    def __init__(self, unit_scale: float):
        self.unit_scale = unit_scale
        self._absolute: dict[int, np.ndarray] = {}

    def __call__(self, product: ifcopenshell.entity_instance) -> np.ndarray:
        if product.ObjectPlacement is None:
            return np.eye(4)
        matrix = self._resolve(product.ObjectPlacement).copy()
        matrix[:3, 3] *= self.unit_scale
        return matrix

    def _resolve(self, placement: ifcopenshell.entity_instance) -> np.ndarray:
        key = placement.id()
        if key not in self._absolute:
            if not placement.is_a("IfcLocalPlacement"):  # grid/linear placements: ifcopenshell's general path
                self._absolute[key] = np.array(ifcopenshell.util.placement.get_local_placement(placement), float)
            else:
                parent = self._resolve(placement.PlacementRelTo) if placement.PlacementRelTo else np.eye(4)
                local = ifcopenshell.util.placement.get_axis2placement(placement.RelativePlacement)
                self._absolute[key] = parent @ np.asarray(local, dtype=float)
        return self._absolute[key]


def read_storeys(ifc: ifcopenshell.file, unit_scale: float) -> list[BimStorey]:
    """Storeys sorted by elevation (metres); storeys without an Elevation sort last."""
    storeys = [BimStorey(s.GlobalId, s.Name, s.Elevation * unit_scale if s.Elevation is not None else None)
               for s in ifc.by_type("IfcBuildingStorey")]
    return sorted(storeys, key=lambda s: (s.elevation is None, s.elevation or 0.0))


def read_zones(ifc: ifcopenshell.file, psets: dict[int, Psets] | None = None) -> list[BimZone]:
    """Spaces and zones (IfcZone groups of spaces) with their off-limits tag."""
    psets = read_all_psets(ifc) if psets is None else psets
    zones = []
    for space in ifc.by_type("IfcSpace"):
        zones.append(_zone(space, psets.get(space.id(), {}), storey_name(space), ()))
    for zone in ifc.by_type("IfcZone"):
        members = tuple(obj.GlobalId for rel in zone.IsGroupedBy or [] for obj in rel.RelatedObjects)
        zones.append(_zone(zone, psets.get(zone.id(), {}), None, members))
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


def _element(el: ifcopenshell.entity_instance, psets: Psets, placement: np.ndarray) -> BimElement:
    element_type = ifcopenshell.util.element.get_type(el)
    family = resolve_family(getattr(element_type, "Name", None), getattr(el, "ObjectType", None), el.Name)
    return BimElement(global_id=el.GlobalId, ifc_class=el.is_a(), name=el.Name, family=family,
                      storey=storey_name(el), placement=placement, psets=psets)


def _property_sets(definitions) -> list[ifcopenshell.entity_instance]:
    """Property sets (and predefined ones like door linings) among definitions; quantity sets dropped.
    IFC4 allows a set of definitions (IfcPropertySetDefinitionSet) where IFC2X3 has one."""
    if definitions is None:
        return []
    if isinstance(definitions, ifcopenshell.entity_instance):
        definitions = [definitions]
    return [d for d in definitions if isinstance(d, ifcopenshell.entity_instance)
            and (d.is_a("IfcPropertySet") or d.is_a("IfcPreDefinedPropertySet"))]


def _zone(entity: ifcopenshell.entity_instance, psets: Psets, storey: str | None,
          members: tuple[str, ...]) -> BimZone:
    tag = psets.get(ZONE_PSET, {})
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
