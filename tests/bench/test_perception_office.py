"""bench perception's real office frame: both pipelines scored against the as-built IFC's furniture, and the
CLI's --seeds 0 runs the office alone."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from bim2rdt.bench.perception.office import office_bench
from bim2rdt.cli import app


def test_the_office_record_scores_verify_and_the_geometric_detector_on_the_five_boxes(sensors):
    record = office_bench(sensors)
    assert record["boxes"] == 5 and not record["miscalibrated"]
    rows = {r["pipeline"]: r for r in record["pipelines"]}
    assert set(rows) == {"verify", "geometric"}
    assert rows["verify"]["recall"] == 1.0 and rows["verify"]["precision"] == 1.0
    assert record["localization_error_m"] < 0.03 and record["localization_error_deg"] < 1.0
    assert all(r["cpu_seconds"] > 0 for r in rows.values())


def test_an_absent_sensor_folder_gives_no_office_record(tmp_path):
    assert office_bench(tmp_path) is None


def test_bench_perception_with_no_seeds_runs_the_office_alone(sensors, tmp_path):
    result = CliRunner().invoke(app, ["bench", "perception", "--seeds", "0", "--sensors", str(sensors), "--out",
                                      str(tmp_path), "--json", "--all-cores"])
    assert result.exit_code == 0, result.output
    record = json.loads(result.output)
    assert "detectors" not in record and record["office"]["boxes"] == 5
