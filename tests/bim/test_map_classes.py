"""Permanent structure is the robot's map: the readiness check says when a model has none, in one line."""

from __future__ import annotations

import ifcopenshell
import ifcopenshell.api.root
import pytest

from bim2rdt.bim import load_ifc
from bim2rdt.bim.map_classes import map_elements
from bim2rdt.bim.readiness import PASS, WARN, check_readiness
from bim2rdt.localization import LocalizationError
from bim2rdt.localization.surfaces import PermanentMap


def _check(model):
    return {c.name: c for c in check_readiness(model, None)}["permanent elements to localize on"]


def test_the_embedded_sites_walls_columns_slab_and_door_are_its_map(site_model):
    classes = sorted({el.ifc_class for el in map_elements(site_model)})
    assert classes == ["IfcColumn", "IfcDoor", "IfcSlab", "IfcWall"]
    assert len(map_elements(site_model)) == 6 + 6 + 1 + 1
    check = _check(site_model)
    assert check.status == PASS and check.summary.startswith("14 permanent elements")


def test_a_model_of_site_objects_only_is_flagged_and_refused_by_the_localizer(site_ifc, tmp_path):
    ifc = ifcopenshell.open(str(site_ifc))
    for element in [*ifc.by_type("IfcWall"), *ifc.by_type("IfcColumn"), *ifc.by_type("IfcSlab"), *ifc.by_type("IfcDoor")]:
        ifcopenshell.api.root.remove_product(ifc, product=element)
    ifc.write(str(tmp_path / "objects_only.ifc"))
    model = load_ifc(tmp_path / "objects_only.ifc", cache_dir=tmp_path)
    check = _check(model)
    assert check.status == WARN and "no map to localize on" in check.summary and "\n" not in check.summary
    with pytest.raises(LocalizationError, match="no walls, columns, slabs, stairs or doors .*info --readiness"):
        PermanentMap.from_model(model)
