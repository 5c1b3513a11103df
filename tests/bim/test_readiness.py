"""The model-conditioning check flags exactly what the paper asks a model to fix before the robot uses it."""

from __future__ import annotations

import ifcopenshell
import ifcopenshell.api.root
import pytest

from bim2rdt.bim import load_ifc
from bim2rdt.bim.readiness import PASS, UNAVAILABLE, WARN, check_readiness
from bim2rdt.semantics import KnowledgeBasePriors


def _by_name(checks):
    return {check.name: check for check in checks}


def test_the_embedded_site_is_ready(site_model):
    checks = _by_name(check_readiness(site_model, KnowledgeBasePriors()))
    assert {name: c.status for name, c in checks.items()} == dict.fromkeys(checks, PASS)
    assert checks["off-limits zones tagged"].examples == ("Exclusion Zone - Material Storage",)


def test_a_neglected_model_is_flagged_item_by_item(site_ifc, tmp_path):
    ifc = ifcopenshell.open(str(site_ifc))
    stray = ifcopenshell.api.root.create_entity(ifc, "IfcBuildingElementProxy")  # no name, type, storey
    odd = ifcopenshell.api.root.create_entity(ifc, "IfcBuildingElementProxy", name="Zorblax_Widget_Q7")
    ifc.by_type("IfcBuildingStorey")[0].Elevation = None
    for space in ifc.by_type("IfcSpace"):
        ifcopenshell.api.root.remove_product(ifc, product=space)
    for conversion in ifc.by_type("IfcMapConversion"):
        ifc.remove(conversion)
    ifc.by_type("IfcSite")[0].RefLatitude = None
    ifc.write(str(tmp_path / "neglected.ifc"))
    checks = _by_name(check_readiness(load_ifc(tmp_path / "neglected.ifc", cache_dir=tmp_path), KnowledgeBasePriors()))
    assert checks["elements without family"].count == 1
    assert checks["elements without storey"].count == 2
    assert checks["storeys without elevation"].examples == ("Ground Floor",)
    assert checks["families the prior table does not know"].examples == ("Zorblax_Widget_Q7",)
    assert checks["off-limits zones tagged"].status == WARN
    assert checks["geo-reference"].status == WARN
    assert checks["elements without family"].examples == (f"IfcBuildingElementProxy {stray.GlobalId}",)
    assert set(checks["elements without storey"].examples) == {  # both new proxies, the odd one by its name
        f"IfcBuildingElementProxy {stray.GlobalId}", f"IfcBuildingElementProxy {odd.Name}"}


def test_without_a_prior_table_that_check_is_unavailable_not_passed(site_model):
    check = _by_name(check_readiness(site_model, None))["families the prior table does not know"]
    assert check.status == UNAVAILABLE


@pytest.mark.parametrize("name", ["Office_A_20110811.ifc"])
def test_a_real_revit_model_has_families_and_storeys_but_no_tagged_off_limits_zone(sample_model, name):
    checks = _by_name(check_readiness(sample_model(name), KnowledgeBasePriors()))
    assert checks["elements without family"].status == PASS
    assert checks["elements without storey"].status == PASS
    assert checks["off-limits zones tagged"].status == WARN


def test_elements_of_an_unnamed_storey_count_as_contained_and_the_storey_goes_by_its_globalid(site_ifc, tmp_path):
    """IfcOpenHouse's storey has no Name and no Elevation; its elements are contained in it all the same."""
    ifc = ifcopenshell.open(str(site_ifc))
    storey = ifc.by_type("IfcBuildingStorey")[0]
    storey.Name, storey.Elevation = None, None
    ifc.write(str(tmp_path / "unnamed.ifc"))
    model = load_ifc(tmp_path / "unnamed.ifc", cache_dir=tmp_path)
    checks = _by_name(check_readiness(model, KnowledgeBasePriors()))
    assert checks["elements without storey"].count == 0
    assert checks["storeys without elevation"].examples == (storey.GlobalId,)
    assert model.storeys[0].name == storey.GlobalId
    assert {el.storey for el in model.elements} == {storey.GlobalId}
