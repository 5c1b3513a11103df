"""The report's reason for a status names the tolerance as judged: a 15 mm band reads 1.5 cm, not a rounded 2 cm."""

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
