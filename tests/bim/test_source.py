"""Every kind of bad input file gives a one-line BimError that says what is wrong."""

from __future__ import annotations

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
