"""`bim2rdt progress MODEL --url TWIN`: the task table, --json in progress.json's shape, --at a past date, and a bad
date as one line."""

from __future__ import annotations

import json
from datetime import date, datetime, timezone

import pytest
from typer.testing import CliRunner

from bim2rdt.bim import load_ifc
from bim2rdt.cli import app
from bim2rdt.perception.observation import Observation
from bim2rdt.sim.site import build_site_ifc
from bim2rdt.twin import DigitalTwin

runner = CliRunner()
SEEN = datetime(2026, 12, 6, 8, 0, tzinfo=timezone.utc)


@pytest.fixture(scope="module")
def site_twin(tmp_path_factory):
    """The site (scheduled around 2026-12-06) and a twin that saw the scaffold standing at 08:00."""
    folder = tmp_path_factory.mktemp("progress-cli")
    path = build_site_ifc(folder / "site.ifc", day=date(2026, 12, 6))
    model = load_ifc(path, cache_dir=folder / "cache")
    scaffold = next(el for el in model.elements if el.family == "Scaffold_Frame_1000x2000")
    with DigitalTwin.open(f"sqlite:///{folder / 'twin.db'}", model) as twin:
        twin.record(Observation(scaffold.family, scaffold.global_id, scaffold.placement, 0.004, 0.9, 200),
                    SEEN.timestamp())
    return path, folder / "twin.db"


def test_the_table_names_each_task_with_its_status(site_twin):
    path, db = site_twin
    result = runner.invoke(app, ["progress", str(path), "--url", str(db)])
    assert result.exit_code == 0, result.output
    line = next(row for row in result.output.splitlines() if "Scaffold erection" in row)
    assert "ahead" in line and "100.0" in line
    assert "Partition north-east room" in result.output


def test_json_is_progress_json_and_at_a_date_before_the_observation_nothing_is_seen(site_twin):
    path, db = site_twin
    now = json.loads(runner.invoke(app, ["progress", str(path), "--url", str(db), "--json"]).output)
    assert datetime.fromisoformat(now["date"]) == SEEN
    before = runner.invoke(app, ["progress", str(path), "--url", str(db), "--at", "2026-12-06T07:00", "--json"])
    assert before.exit_code == 0, before.output
    tasks = {t["identification"]: t for t in json.loads(before.output)["tasks"]}
    assert tasks["T.4"]["status"] == "unknown" and tasks["T.4"]["products"]["not observed"] == 1


def test_a_bad_date_is_one_line_and_exit_2(site_twin):
    path, db = site_twin
    result = runner.invoke(app, ["progress", str(path), "--url", str(db), "--at", "yesterday"])
    assert result.exit_code == 2 and "--at 'yesterday' is not an ISO 8601 date" in result.output
