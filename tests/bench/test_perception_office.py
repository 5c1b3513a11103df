"""bench perception's real office frame: both pipelines scored against the as-built IFC's furniture, and the
CLI's --seeds 0 runs the office alone."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from bim2rdt.bench.perception.office import office_bench
from bim2rdt.cli import app


@pytest.fixture(scope="module")
def no_seeds(sensors, tmp_path_factory) -> dict:
    """`bench perception --seeds 0 --json`: its record, whose ``office`` is what ``office_bench`` returned (the
    office frame is scored once for the tests of this file)."""
    result = CliRunner().invoke(app, ["bench", "perception", "--seeds", "0", "--sensors", str(sensors), "--out",
                                      str(tmp_path_factory.mktemp("perception")), "--json", "--all-cores"])
    assert result.exit_code == 0, result.output
    return json.loads(result.output)


def test_the_office_record_scores_verify_and_the_geometric_detector_on_the_five_boxes(no_seeds):
    record = no_seeds["office"]
    assert record["boxes"] == 5 and not record["miscalibrated"]
    rows = {r["pipeline"]: r for r in record["pipelines"]}
    assert set(rows) == {"verify", "geometric"}
    assert rows["verify"]["recall"] == 1.0 and rows["verify"]["precision"] == 1.0
    assert record["localization_error_m"] < 0.03 and record["localization_error_deg"] < 1.0
    assert all(r["cpu_seconds"] > 0 for r in rows.values())


def test_an_absent_sensor_folder_gives_no_office_record(tmp_path):
    assert office_bench(tmp_path) is None


def test_bench_perception_with_no_seeds_runs_the_office_alone(no_seeds):
    assert "detectors" not in no_seeds and no_seeds["office"]["boxes"] == 5
