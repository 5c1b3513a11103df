"""Permanent structure is the robot's map: the readiness check says when a model has none, in one line."""

from __future__ import annotations

import subprocess
import sys

import ifcopenshell
import ifcopenshell.api.root
import pytest

from bim2rdt.bim import load_ifc
from bim2rdt.bim.map_classes import NO_MAP, map_elements
from bim2rdt.bim.readiness import PASS, WARN, check_readiness
from bim2rdt.localization import LocalizationError
from bim2rdt.localization.surfaces import PermanentMap


def _check(model):
    return {c.name: c for c in check_readiness(model, None)}["permanent elements to localize on"]


def test_the_embedded_sites_walls_columns_slab_and_door_are_its_map(site_model):
    classes = sorted({el.ifc_class for el in map_elements(site_model)})
    assert classes == ["IfcColumn", "IfcDoor", "IfcSlab", "IfcWall"]
    assert len(map_elements(site_model)) == 7 + 6 + 1 + 1  # 6 walls and the partition the day has not built
    check = _check(site_model)
    assert check.status == PASS and check.summary.startswith("15 permanent elements")


def _objects_only(site_ifc, tmp_path):
    ifc = ifcopenshell.open(str(site_ifc))
    for element in [*ifc.by_type("IfcWall"), *ifc.by_type("IfcColumn"), *ifc.by_type("IfcSlab"), *ifc.by_type("IfcDoor")]:
        ifcopenshell.api.root.remove_product(ifc, product=element)
    ifc.write(str(tmp_path / "objects_only.ifc"))
    return tmp_path / "objects_only.ifc"


def test_a_model_of_site_objects_only_is_flagged_and_refused_by_the_localizer(site_ifc, tmp_path):
    model = load_ifc(_objects_only(site_ifc, tmp_path), cache_dir=tmp_path)
    check = _check(model)
    assert check.status == WARN and "no map to localize on" in check.summary and "\n" not in check.summary
    with pytest.raises(LocalizationError, match="no walls, columns, slabs, stairs or doors .*info --readiness") as refused:
        PermanentMap.from_model(model)
    assert NO_MAP in check.summary and NO_MAP in str(refused.value)  # the same words in both places


def _info(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "bim2rdt", "info", *args], capture_output=True, text=True,
                          timeout=300)


def test_info_require_map_exits_1_in_one_line_on_a_model_without_a_map(site_ifc, tmp_path):
    path = _objects_only(site_ifc, tmp_path)
    warned = _info(str(path), "--readiness")
    assert warned.returncode == 0 and "no map to localize on" in warned.stdout  # a report: the warning row
    for geometry in ("--geometry", "--no-geometry"):
        refused = _info(str(path), "--readiness", "--require-map", geometry)
        assert refused.returncode == 1 and "BIM readiness" in refused.stdout  # the report, then the error
        assert refused.stderr.strip().count("\n") == 0 and f"--require-map: {NO_MAP}" in refused.stderr


def test_info_require_map_passes_a_model_with_its_walls(site_ifc):
    result = _info(str(site_ifc), "--require-map", "--json")
    assert result.returncode == 0, result.stderr
