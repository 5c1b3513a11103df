"""Every kind of bad input file gives a one-line BimError that says what is wrong."""

from __future__ import annotations

import re

import pytest

from bim2rdt.bim import BimError, load_ifc
from bim2rdt.errors import Bim2RdtError

SMALL = "construction_scheduling_task.ifc"


def _variant(samples, tmp_path, name: str, edit) -> str:
    text = (samples / SMALL).read_text(encoding="latin-1")
    path = tmp_path / name
    path.write_text(edit(text), encoding="latin-1")
    return path


def _reason(path) -> str:
    with pytest.raises(BimError) as caught:
        load_ifc(path)
    message = str(caught.value)
    assert "\n" not in message
    return message


def test_bim_error_is_a_project_error_so_the_cli_prints_one_line():
    assert issubclass(BimError, Bim2RdtError)


def test_a_missing_file_is_named(tmp_path):
    assert "no such IFC file" in _reason(tmp_path / "absent.ifc")


def test_a_folder_is_not_a_file(tmp_path):
    assert "not a file" in _reason(tmp_path)


def test_an_empty_file_is_reported_as_empty(tmp_path):
    (tmp_path / "empty.ifc").write_bytes(b"")
    assert "empty" in _reason(tmp_path / "empty.ifc")


def test_a_file_that_is_not_step_is_reported(tmp_path):
    (tmp_path / "notes.ifc").write_text("just some notes\n")
    assert "not an IFC-SPF file" in _reason(tmp_path / "notes.ifc")


def test_a_truncated_file_is_reported_even_though_ifcopenshell_would_parse_it(samples, tmp_path):
    path = _variant(samples, tmp_path, "cut.ifc", lambda text: text[: len(text) // 2])
    assert "truncated" in _reason(path)


def test_an_invalid_string_escape_is_located(samples, tmp_path):
    path = _variant(samples, tmp_path, "escape.ifc", lambda text: text.replace("'Wall #1'", "'Wall \\X2\\00G1\\X0\\ #1'"))
    reason = _reason(path)
    assert "invalid STEP string escape" in reason and "byte" in reason


def test_an_unknown_schema_is_named(samples, tmp_path):
    path = _variant(samples, tmp_path, "ifc9.ifc", lambda text: text.replace("FILE_SCHEMA(('IFC4'))", "FILE_SCHEMA(('IFC9X9'))"))
    reason = _reason(path)
    assert "unknown IFC schema" in reason and "IFC9X9" in reason


# Damage ifcopenshell reads past or crashes on, made by editing one line of the embedded site.

def test_a_line_that_lost_its_closing_bracket_is_named_instead_of_dropping_the_rest_of_the_file(site_text):
    wall = site_text.line(r"=IFCWALL\(")
    reason = _reason(site_text.replace(wall, wall[:-2]))  # ifcopenshell alone: exit 0, most elements gone
    assert reason.startswith(f"variant.ifc: #{site_text.entity_id(wall)} on line {site_text.line_number(wall)} does "
                             "not end where it should (a lost ');'?) and swallows the ")
    after = site_text.text.splitlines()[site_text.line_number(wall)]
    assert f"entities after it, from #{site_text.entity_id(after)} on line {site_text.line_number(after)}" in reason


def test_an_unknown_entity_name_is_an_error_with_its_line(site_text):
    column = site_text.line(r"=IFCCOLUMN\(")
    reason = _reason(site_text.replace(column, column.replace("IFCCOLUMN(", "IFCCOLUMNN(")))
    assert reason.startswith(f"variant.ifc: line {site_text.line_number(column)}: ") and "IFCCOLUMNN" in reason


def test_a_duplicate_entity_id_is_refused_before_ifcopenshell_sees_it(site_text):
    slab = site_text.line(r"=IFCSLAB\(")
    before = site_text.text.splitlines()[site_text.line_number(slab) - 2]
    reason = _reason(site_text.replace(slab, slab.replace(f"#{site_text.entity_id(slab)}=",
                                                          f"#{site_text.entity_id(before)}=")))
    assert (f"#{site_text.entity_id(before)} is declared twice (lines {site_text.line_number(slab) - 1} and "
            f"{site_text.line_number(slab)})") in reason


def test_an_id_written_inside_a_string_is_not_a_declaration(site_text):
    wall = site_text.line(r"=IFCWALL\(")
    name = re.search(r"'Exterior Wall[^']*'", wall).group(0)
    model = load_ifc(site_text.replace(wall, wall.replace(name, "'Wall #1=A'' and #1 =B'")))
    assert any(el.name == "Wall #1=A' and #1 =B" for el in model.elements)


def test_a_file_without_an_ifcproject_is_an_error_not_an_index_error(site_text):
    project = site_text.line(r"=IFCPROJECT\(")
    assert "no IfcProject" in _reason(site_text.replace(project + "\n", ""))


@pytest.mark.parametrize("value, shown", [("'x'", "'x'"), ("#3", "#3")], ids=["a string", "a wrong entity"])
def test_a_placement_of_the_wrong_type_names_the_attribute_and_line(site_text, value, shown):
    wall = site_text.line(r"=IFCWALL\(")
    placement = re.search(r",(#\d+),#\d+,\$,\.SOLIDWALL\.", wall).group(1)
    reason = _reason(site_text.replace(wall, wall.replace(f",{placement},", f",{value},")))
    assert reason.startswith(f"variant.ifc: line {site_text.line_number(wall)}: #{site_text.entity_id(wall)} "
                             "IfcWall.ObjectPlacement is ")
    assert shown in reason and "not a valid IfcObjectPlacement" in reason


def test_a_global_id_that_is_a_number_names_the_attribute(site_text):
    wall = site_text.line(r"=IFCWALL\(")
    guid = re.search(r"IFCWALL\(('[^']*')", wall).group(1)
    reason = _reason(site_text.replace(wall, wall.replace(guid, "42")))
    assert f"#{site_text.entity_id(wall)} IfcWall.GlobalId is 42" in reason


def test_a_placement_with_too_few_arguments_names_the_entity(site_text):
    placement = site_text.line(r"=IFCLOCALPLACEMENT\(#\d+,#\d+\);")
    short = re.sub(r",#\d+\);$", ");", placement)
    reason = _reason(site_text.replace(placement, short))
    assert f"line {site_text.line_number(placement)}: #{site_text.entity_id(placement)} IfcLocalPlacement" in reason
    assert "Expected 2 attribute values, found 1" in reason
