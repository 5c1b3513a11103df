"""The fast whole-file readers (psets, placements, storeys, types) agree with ifcopenshell's own per-element utilities on every sample element."""

from __future__ import annotations

import ifcopenshell
import ifcopenshell.util.element
import ifcopenshell.util.placement
import ifcopenshell.util.unit
import numpy as np
import pytest

from bim2rdt.bim.psets import read_all_psets
from bim2rdt.bim.spatial import PlacementResolver, SpatialIndex

NAMES = ["AC20-FZK-Haus.ifc", "Duplex_A_20110907.ifc", "Office_A_20110811.ifc", "TestModel_IFC4Add2.ifc",
         "construction_scheduling_task.ifc"]


@pytest.mark.parametrize("name", NAMES)
def test_bulk_psets_and_cached_placements_match_ifcopenshell_per_element(samples, name):
    ifc = ifcopenshell.open(str(samples / name))
    scale = ifcopenshell.util.unit.calculate_unit_scale(ifc)
    psets, placements, index = read_all_psets(ifc), PlacementResolver(scale), SpatialIndex(ifc)
    for element in [*ifc.by_type("IfcElement"), *ifc.by_type("IfcSpace")]:
        reference = ifcopenshell.util.element.get_psets(element, psets_only=True)
        ours = psets.get(element.id(), {})
        assert ours.keys() == reference.keys()
        for pset, props in reference.items():
            assert ours[pset] == {k: list(v) if isinstance(v, tuple) else v for k, v in props.items() if k != "id"}
        expected = np.array(ifcopenshell.util.placement.get_local_placement(element.ObjectPlacement))
        expected[:3, 3] *= scale
        assert np.allclose(placements(element), expected)
        storey = ifcopenshell.util.element.get_container(element, ifc_class="IfcBuildingStorey")
        if storey is None and (parent := ifcopenshell.util.element.get_aggregate(element)) is not None:
            storey = parent if parent.is_a("IfcBuildingStorey") else None  # spaces are aggregated, not contained
        assert index.storey_of(element) == ((storey.Name or storey.GlobalId) if storey is not None else None)
        assert index.type_of(element) == ifcopenshell.util.element.get_type(element)
