"""Where things are: world placements (metres) and the storey each product stands in, for a whole file.

Both are resolved with one pass over the relations and memoised parents (shared storey/host placements are
computed once), instead of ifcopenshell's per-element walks; the tests check them element by element against
``get_local_placement`` and ``get_container``.
"""

from __future__ import annotations

import ifcopenshell
import ifcopenshell.util.placement
import numpy as np


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


class SpatialIndex:
    """Containment, aggregation, nesting, voids/fillings and typing of a file, indexed once by entity id."""

    def __init__(self, ifc: ifcopenshell.file):
        self._parent: dict[int, ifcopenshell.entity_instance] = {}
        for rel in ifc.by_type("IfcRelContainedInSpatialStructure"):
            for element in rel.RelatedElements:
                self._parent[element.id()] = rel.RelatingStructure
        for rel_class in ("IfcRelAggregates", "IfcRelNests"):
            for rel in ifc.by_type(rel_class):
                for part in rel.RelatedObjects:
                    self._parent.setdefault(part.id(), rel.RelatingObject)
        for rel in ifc.by_type("IfcRelVoidsElement"):  # an opening stands where its host stands
            self._parent.setdefault(rel.RelatedOpeningElement.id(), rel.RelatingBuildingElement)
        for rel in ifc.by_type("IfcRelFillsElement"):  # and a door/window where its opening does
            self._parent.setdefault(rel.RelatedBuildingElement.id(), rel.RelatingOpeningElement)
        self._type = {element.id(): rel.RelatingType for rel in ifc.by_type("IfcRelDefinesByType")
                      for element in rel.RelatedObjects}

    def storey_of(self, product: ifcopenshell.entity_instance) -> str | None:
        """The storey a product stands in: directly, through a space, or through the assembly it is part of."""
        current = product
        for _ in range(16):
            parent = self._parent.get(current.id())
            if parent is None:
                return None
            if parent.is_a("IfcBuildingStorey"):
                return storey_name(parent)
            current = parent
        return None

    def type_of(self, product: ifcopenshell.entity_instance) -> ifcopenshell.entity_instance | None:
        """The product's type object (IfcRelDefinesByType), if any."""
        return self._type.get(product.id())


def storey_name(storey: ifcopenshell.entity_instance) -> str:
    """How a storey is named everywhere (elements' ``storey``, ``BimStorey.name``, maps, errors): its Name, or its
    GlobalId when the file leaves it unnamed (IfcOpenHouse's storey has no Name: its elements are contained all
    the same)."""
    return storey.Name or storey.GlobalId


def placement_matrix(product: ifcopenshell.entity_instance, unit_scale: float) -> np.ndarray:
    """ObjectPlacement as a 4x4 world matrix in metres (ifcopenshell returns project units)."""
    if product.ObjectPlacement is None:
        return np.eye(4)
    matrix = np.array(ifcopenshell.util.placement.get_local_placement(product.ObjectPlacement), dtype=float)
    matrix[:3, 3] *= unit_scale
    return matrix


