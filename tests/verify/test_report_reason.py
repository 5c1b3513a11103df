"""The report says what was judged in words a site manager reads: a tolerance as judged (a 15 mm band reads 1.5 cm,
not a rounded 2 cm), and each structural element by its name with its offset."""

from __future__ import annotations

from bim2rdt.twin import Deviation, ElementState, ElementStatus, Tolerance
from bim2rdt.verify.report.rows import reason


def state(status: ElementStatus, deviation: Deviation) -> ElementState:
    return ElementState("0wall", "Wall", "IfcWall", status, Tolerance("structure LOA30", 0.015, 1.0), deviation)


def test_a_structural_tolerance_reads_as_judged():
    assert reason(state(ElementStatus.AS_PLANNED, Deviation(0.010, 0.7, 0.0))) == \
        "within the 'structure LOA30' tolerance (1.5 cm, 1°)"


def test_a_deviation_names_what_is_beyond_the_tolerance():
    words = reason(state(ElementStatus.DEVIATING, Deviation(0.018, 0.4, 1.5)))
    assert words == "off by 1.8 cm, turned 1.5°: beyond the 'structure LOA30' tolerance (1.5 cm, 1°)"


def test_the_structure_table_names_each_element_and_shows_its_offset():
    from bim2rdt.verify.report.page import _structure

    element = {"global_id": "2JZZ", "ifc_class": "IfcWall", "status": "as planned", "coverage": 0.927,
               "median_mm": 10.4, "p95_mm": 94.3, "offset_m": [0.0, -0.0104, 0.0], "rotation_deg": 0.7,
               "frames": [0], "reason": "offset 10 mm"}
    html = _structure([element], {"2JZZ": "Back wall (door wall)"})
    assert "Back wall (door wall)" in html and "2JZZ" in html
    assert "<td>1.0</td>" in html  # the offset, cm
