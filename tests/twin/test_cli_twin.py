"""`bim2rdt twin state|history|export` on a twin recorded in the test: tables and JSON, a past time, exports,
and one-line errors for a missing twin or a bad time."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from bim2rdt.perception.observation import Observation
from bim2rdt.twin import DigitalTwin

from twin_helpers import T0


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "bim2rdt", "twin", *map(str, args)], capture_output=True,
                          text=True, timeout=300)


@pytest.fixture
def recorded(tmp_path, site_ifc, site_model):
    url = f"sqlite:///{tmp_path / 'twin.db'}"
    cone = next(el for el in site_model.elements if el.family == "Traffic_Cone_Orange_70cm")
    moved = cone.placement.copy()
    moved[1, 3] += 0.4
    with DigitalTwin.open(url, site_model) as twin:
        twin.record(Observation(cone.family, cone.global_id, cone.placement, 0.004, 0.9, 200), T0)
        twin.record(Observation(cone.family, cone.global_id, moved, 0.004, 0.9, 200), T0 + 60)
    return url, cone


def test_state_prints_the_present_and_the_past(recorded, site_ifc, site_model):
    url, cone = recorded
    now = _cli("state", site_ifc, "--url", url, "--json")
    assert now.returncode == 0, now.stderr
    (state,) = json.loads(now.stdout)
    assert (state["global_id"], state["status"]) == (cone.global_id, "deviating")
    assert state["deviation"]["translation"] == pytest.approx(0.4)
    past = json.loads(_cli("state", site_ifc, "--url", url, "--json", "--at", str(T0 + 30)).stdout)
    assert [s["status"] for s in past] == ["as planned"]
    everything = json.loads(_cli("state", site_ifc, "--url", url, "--json", "--all").stdout)
    assert len(everything) == len(site_model.elements)
    table = _cli("state", site_ifc, "--url", url)
    assert "deviating" in table.stdout and "temporary 5cm/5°" in table.stdout


def test_history_lists_the_element_s_changes(recorded, site_ifc):
    url, cone = recorded
    result = _cli("history", site_ifc, cone.global_id, "--url", url, "--json")
    assert result.returncode == 0, result.stderr
    kinds = [(e["kind"], e["data"].get("to")) for e in json.loads(result.stdout)]
    assert kinds == [("observation", None), ("status", "as planned"), ("observation", None), ("status", "deviating")]


def test_export_writes_ifc_bcf_and_json(recorded, site_ifc, tmp_path):
    url, _ = recorded
    result = _cli("export", site_ifc, "--url", url, "--out", tmp_path / "export")
    assert result.returncode == 0, result.stderr
    for name in ("twin.ifc", "issues.bcf", "twin.json"):
        assert (tmp_path / "export" / name).stat().st_size > 0


def test_a_missing_twin_is_a_one_line_error_and_is_not_created(site_ifc, tmp_path):
    result = _cli("state", site_ifc, "--url", f"sqlite:///{tmp_path / 'none.db'}")
    assert result.returncode == 1
    assert result.stderr.strip().startswith("error: no twin at sqlite:///") and len(result.stderr.splitlines()) == 1
    assert not (tmp_path / "none.db").exists()


def test_a_time_that_is_no_time_is_a_usage_error(recorded, site_ifc):
    result = _cli("state", site_ifc, "--url", recorded[0], "--at", "yesterday")
    assert result.returncode == 2 and "neither ISO 8601 nor Unix seconds" in result.stderr


def test_a_plain_path_is_taken_as_the_sqlite_file_and_globalids_are_shown_whole(recorded, site_ifc, tmp_path):
    _, cone = recorded
    result = _cli("state", site_ifc, "--url", tmp_path / "twin.db")
    assert result.returncode == 0, result.stderr
    assert cone.global_id in result.stdout and f"{cone.global_id[:-1]}…" not in result.stdout


def test_twin_url_keeps_urls_and_makes_a_plain_path_sqlite(tmp_path):
    from bim2rdt.cli.twin import twin_url

    assert twin_url("postgresql+psycopg://u:p@h/db") == "postgresql+psycopg://u:p@h/db"
    assert twin_url("sqlite:///x/twin.db") == "sqlite:///x/twin.db"
    assert twin_url(str(tmp_path / "twin.db")) == f"sqlite:///{tmp_path / 'twin.db'}"
