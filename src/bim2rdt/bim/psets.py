"""Property sets of a whole IFC file in one pass (psets only: quantity sets are derived numbers, not data).

``ifcopenshell.util.element.get_psets`` per element walks the inverse relations of every element (~0.6 s on
Office_A); one pass over the relations, converting each property set once, gives the same result in ~0.15 s
(checked element by element against ``get_psets`` in the tests).
"""

from __future__ import annotations

from typing import Any

import ifcopenshell
import ifcopenshell.util.element

from bim2rdt.bim.records import Psets


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


def read_psets(entity: ifcopenshell.entity_instance) -> Psets:
    """Property sets (inherited from the type too) as {pset: {property: value}}, ifcopenshell ids dropped."""
    psets = ifcopenshell.util.element.get_psets(entity, psets_only=True)
    return {name: {key: _plain(value) for key, value in props.items() if key != "id"}
            for name, props in psets.items()}


def _property_sets(definitions) -> list[ifcopenshell.entity_instance]:
    """Property sets (and predefined ones like door linings) among definitions; quantity sets dropped.
    IFC4 allows a set of definitions (IfcPropertySetDefinitionSet) where IFC2X3 has one."""
    if definitions is None:
        return []
    if isinstance(definitions, ifcopenshell.entity_instance):
        definitions = [definitions]
    return [d for d in definitions if isinstance(d, ifcopenshell.entity_instance)
            and (d.is_a("IfcPropertySet") or d.is_a("IfcPreDefinedPropertySet"))]


def _plain(value: Any) -> Any:
    """Pset values as JSON-friendly Python values (tuples from list/enumerated properties become lists)."""
    if isinstance(value, tuple | list):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, ifcopenshell.entity_instance):
        return str(value)
    return value
