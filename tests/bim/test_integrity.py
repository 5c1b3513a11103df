"""What the reader reads past is said, with the elements it affects: it never loads a damaged model quietly."""

from __future__ import annotations

import re
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from bim2rdt.bim import BimWarning, load_ifc
from bim2rdt.bim.integrity import DANGLING, PARSER, SCHEMA, affected_elements, schema_violations
from bim2rdt.bim.readiness import PASS, WARN, check_readiness
from bim2rdt.bim.source import open_ifc

SAMPLES = ["AC20-FZK-Haus.ifc", "Duplex_A_20110907.ifc", "Office_A_20110811.ifc", "TestModel_IFC4Add2.ifc",
           "construction_scheduling_task.ifc"]


def _wall_with(site_text, attribute_pattern: str, value: str):
    """The site with the first wall's attribute (matched by a regex group) replaced; (path, wall line, guid)."""
    wall = site_text.line(r"=IFCWALL\(")
    match = re.search(attribute_pattern, wall)
    edited = wall[:match.start(1)] + value + wall[match.end(1):]
    return site_text.replace(wall, edited), wall, re.search(r"IFCWALL\('([^']*)'", wall).group(1)


def test_a_placement_pointing_at_a_missing_entity_is_a_warning_naming_the_wall(site_text, tmp_path):
    path, wall, guid = _wall_with(site_text, r",(#\d+),#\d+,\$,\.SOLIDWALL\.", "#999999")
    model = load_ifc(path, cache_dir=tmp_path)
    [warning] = model.warnings
    assert warning.kind == DANGLING and warning.elements == (guid,)
    assert warning.message.startswith(f"#{site_text.entity_id(wall)} IfcWall.ObjectPlacement refers to #999999, "
                                      "which the file does not declare")
    assert "affects IfcWall 'Exterior Wall - South'" in warning.message
    assert np.allclose(model.element(guid).position, 0.0)  # it is at the origin: that is why it must be said


def test_readiness_reports_dangling_references(site_text, tmp_path, site_model):
    path, _, _ = _wall_with(site_text, r",(#\d+),#\d+,\$,\.SOLIDWALL\.", "#999999")
    checks = {c.name: c for c in check_readiness(load_ifc(path, cache_dir=tmp_path), None)}
    check = checks["references to missing entities"]
    assert check.status == WARN and check.count == 1 and "#999999" in check.examples[0]
    clean = {c.name: c for c in check_readiness(site_model, None)}["references to missing entities"]
    assert clean.status == PASS and clean.count == 0


def test_a_missing_storey_placement_affects_every_element_placed_on_the_storey(site_text, tmp_path, site_model):
    storey = site_text.line(r"=IFCBUILDINGSTOREY\(")
    placement = re.search(r",(#\d+),\$,\$,\$,", storey).group(1)
    line = site_text.line(rf"^{placement}=IFCLOCALPLACEMENT\(")
    parent = re.search(r"IFCLOCALPLACEMENT\((#\d+),", line).group(1)
    model = load_ifc(site_text.replace(line, line.replace(f"({parent},", "(#999999,")), cache_dir=tmp_path)
    [warning] = model.warnings
    on_storey = {el.global_id for el in site_model.elements if el.storey == "Ground Floor"}
    assert len(on_storey) > 10 and on_storey <= set(warning.elements)
    assert re.search(r"affects IfcBuildingStorey 'Ground Floor' and \d+ more", warning.message)


def test_an_entity_with_too_few_attributes_that_still_reads_is_listed_with_its_element(site_text, tmp_path):
    wall = site_text.line(r"=IFCWALL\(")
    model = load_ifc(site_text.replace(wall, wall.replace(",.SOLIDWALL.);", ");")), cache_dir=tmp_path)
    [warning] = model.warnings
    assert warning.kind == PARSER and warning.elements == (re.search(r"IFCWALL\('([^']*)'", wall).group(1),)
    assert warning.message.startswith(f"#{site_text.entity_id(wall)} IfcWall: Expected 9 attribute values, found 8")


def test_warnings_survive_the_model_cache(site_text, tmp_path):
    path, _, _ = _wall_with(site_text, r",(#\d+),#\d+,\$,\.SOLIDWALL\.", "#999999")
    first = load_ifc(path, cache_dir=tmp_path)
    again = load_ifc(path, cache_dir=tmp_path)
    assert again.from_cache and again.warnings == first.warnings and len(again.warnings) == 1


def test_validate_finds_a_value_of_the_wrong_type_the_reader_never_reads(site_text, tmp_path):
    path, wall, guid = _wall_with(site_text, r",(\$),\.SOLIDWALL\.", "3.5")  # Tag: an IfcIdentifier (text)
    assert load_ifc(path, geometry=False).warnings == []
    [warning] = load_ifc(path, geometry=False, validate=True).warnings
    assert warning == BimWarning(SCHEMA, f"#{site_text.entity_id(wall)} IfcWall.Tag is 3.5, which is not a valid "
                                 "IfcIdentifier; affects IfcWall 'Exterior Wall - South'", (site_text.entity_id(wall),),
                                 (guid,))


def test_the_embedded_site_is_schema_valid(site_ifc):
    assert schema_violations(open_ifc(site_ifc)) == []


def test_affected_elements_of_a_property_set_are_the_objects_it_is_attached_to(site_ifc):
    ifc = open_ifc(site_ifc)
    relation = ifc.by_type("IfcRelDefinesByProperties")[0]
    expected = {obj.GlobalId for obj in relation.RelatedObjects if obj.is_a("IfcProduct")}
    assert expected and set(affected_elements(ifc, relation.RelatingPropertyDefinition)) == expected


@pytest.mark.samples
@pytest.mark.parametrize("name", SAMPLES)
def test_real_files_load_without_warnings_and_without_schema_type_violations(sample_model, samples, name):
    assert sample_model(name).warnings == []
    assert schema_violations(open_ifc(samples / name)) == []


def test_the_parse_logger_lives_as_long_as_its_file(site_ifc):
    """The file keeps a raw pointer to its logger; freeing the logger first segfaults the next rooted entity
    created (as the twin writer does)."""
    code = textwrap.dedent(f"""
        import gc
        import ifcopenshell.guid
        from bim2rdt.bim.source import open_ifc
        for _ in range(20):
            ifc = open_ifc({str(site_ifc)!r})
            gc.collect()
            for k in range(20):
                ifc.createIfcBuildingElementProxy(ifcopenshell.guid.new(), Name=f"proxy {{k}}")
        print("ok")
    """)
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0 and result.stdout.strip() == "ok", result.stderr[-500:]
