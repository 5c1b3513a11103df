"""The site report's observation table: the same cells in the terminal and in report.md, and a dash where an
observation has no simulated truth to be scored against (a real robot's)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

from bim2rdt.demo.site_report import OBSERVATION_COLUMNS, _markdown, observation_cells


def _row(**change):
    row = {"family": "Steel_Drum_55gal", "label": "steel drum", "global_id": None, "status": "new", "truth": None,
           "upright_bias": 0.8, "shift_m": 0.0, "yaw_deg": 0.0, "tilt_deg": 1.26, "points": 120, "fitness": 0.913,
           "rmse_m": 0.004, "error_rotation_deg": None, "error_translation_m": None, "error_tilt_deg": None}
    return {**row, **change}


def test_an_observation_without_truth_shows_dashes_for_its_errors():
    cells = observation_cells(_row())
    assert len(cells) == len(OBSERVATION_COLUMNS)
    assert cells == ("steel drum", "new", "-", "0.80", "0.00", "0.0", "1.3", "0.91", "-", "-")


def test_an_observation_with_truth_shows_its_errors_in_centimetres_and_degrees():
    cells = observation_cells(_row(truth="unplanned", error_translation_m=0.0123, error_rotation_deg=2.04))
    assert cells[2] == "unplanned" and cells[-2:] == ("1.2", "2.0")


def test_the_markdown_table_has_one_full_row_per_observation():
    day = SimpleNamespace(twin_path=Path("site_twin.ifc"), mission=SimpleNamespace(not_seen=[], set_aside=[]),
                          twin_records=[],
                          route=None)
    rows = [_row(), _row(truth="unplanned", error_translation_m=0.01, error_rotation_deg=1.0)]
    text = _markdown(day, rows, {"hav_events": []})
    table = [line for line in text.splitlines() if line.startswith("| Steel_Drum_55gal |")]
    assert len(table) == 2
    assert all(line.count("|") == len(OBSERVATION_COLUMNS) + 2 for line in table)
    assert table[0].endswith("| - | - |") and table[1].endswith("| 1.0 | 1.0 |")
