"""`demo --ifc` on every sample building: the robot visits at least one station, or the command exits 1 with
one line saying why (never exit 0 with empty tables). Kept affordable with the cheapest settings of the same
code path: one site object (so one station), one worker, one minute of tool work. Each building runs once: the
IFC2X3 one (Duplex) and the one with no floor (its error, and no empty --out folder left behind) are checked
further on the same runs."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.samples

_SAMPLES = Path(os.environ.get("BIM2RDT_SAMPLES",
                               Path(__file__).resolve().parents[2].parent / "shared" / "data" / "ifc"))
BUILDINGS = sorted(p.name for p in _SAMPLES.glob("*.ifc")) if _SAMPLES.is_dir() else []
"""Every sample building, listed when the tests are collected (the ``samples`` fixture skips when absent)."""


@pytest.fixture(scope="module")
def demo_ifc(samples, tmp_path_factory):
    """``demo_ifc(name)``: (the finished process, its --out folder) of `demo --ifc name` with this file's cheapest
    settings, run once per building for the tests of this file (read-only)."""
    runs = {}

    def run(name: str) -> tuple[subprocess.CompletedProcess, Path]:
        if name not in runs:
            out = tmp_path_factory.mktemp("demo-ifc") / "out"
            command = ["demo", "--ifc", str(samples / name), "--out", str(out), "--objects", "1", "--workers", "1",
                       "--minutes", "1"]
            runs[name] = (subprocess.run([sys.executable, "-m", "bim2rdt", *command], capture_output=True, text=True,
                                         timeout=900), out)
        return runs[name]

    return run


@pytest.mark.parametrize("name", BUILDINGS)
def test_demo_ifc_visits_a_station_or_exits_1_saying_why(demo_ifc, name):
    result, out = demo_ifc(name)
    assert "Traceback" not in result.stderr
    if result.returncode == 0:
        route = json.loads((out / "site_day.json").read_text())["route"]
        assert route["visited"] >= 1 and route["visited"] == route["stations"] - len(route["skipped"])
    else:
        assert result.returncode == 1, result.stderr
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error: ") and len(lines[0]) > len("error: ") + 20


def test_an_ifc2x3_building_runs_without_ifc_write_back_and_says_why(demo_ifc):
    result, out = demo_ifc("Duplex_A_20110907.ifc")
    assert result.returncode == 0, result.stderr
    assert "not written back (IFC2X3: IFC write-back needs IFC4)" in result.stdout
    assert not (out / "site_twin.ifc").exists() and (out / "site.ifc").is_file()
    assert "IFC write-back needs IFC4" in (out / "report.md").read_text()
    assert json.loads((out / "config.json").read_text())["detector"] == "geometric"


def test_a_building_with_no_floor_to_stand_on_is_a_one_line_error(demo_ifc):
    """The spec's 4D example has a wall but no slab or space on any storey: nowhere to put the robot."""
    result, out = demo_ifc("construction_scheduling_task.ifc")
    assert result.returncode == 1 and "Traceback" not in result.stderr
    assert result.stderr.strip() == ("error: construction_scheduling_task.ifc: no storey has a slab (or a space) to "
                                     "take its floor from")


def test_a_failed_run_leaves_no_empty_folder_it_made(demo_ifc):
    result, out = demo_ifc("construction_scheduling_task.ifc")
    assert result.returncode == 1 and result.stderr.startswith("error: ")
    assert not out.exists()


def test_a_day_that_visits_no_station_is_an_error_saying_why(tmp_path):
    from types import SimpleNamespace

    from bim2rdt.cli.demo import _fail_without_a_station
    from bim2rdt.demo.routes import why_no_station
    from bim2rdt.planning import PlanningError

    route = SimpleNamespace(plan=SimpleNamespace(unplaced={"a": "Steel_Drum_55gal: no free, reachable viewpoint"}),
                            route=SimpleNamespace(arrivals={}, skipped={1: "no path to (3.0, 4.0)"}))
    assert why_no_station(route) == "Steel_Drum_55gal: no free, reachable viewpoint; no path to (3.0, 4.0)"
    with pytest.raises(PlanningError, match="visited no station.*Steel_Drum_55gal: no free"):
        _fail_without_a_station(SimpleNamespace(route=route), tmp_path)
    route.route.arrivals[0] = 0.0
    assert why_no_station(route) is None
    _fail_without_a_station(SimpleNamespace(route=route), tmp_path)
