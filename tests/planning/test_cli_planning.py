"""`bim2rdt plan` and `bim2rdt bench planning`: output, files, JSON, and exit codes (0 ok, 1 bad input, 2 usage)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "bim2rdt", *args], capture_output=True, text=True, timeout=300)


def test_plan_prints_a_path_through_the_door_and_writes_the_nav2_map_and_plot(site_model, tmp_path):
    result = run_cli("plan", str(site_model.path), "--from", "1,1", "--to", "16,10", "--out", str(tmp_path), "--json")
    assert result.returncode == 0, result.stderr
    payload = json.loads(result.stdout)
    path = np.array(payload["path"])
    assert path[0].tolist() == [1.0, 1.0] and path[-1].tolist() == [16.0, 10.0]
    assert payload["storey"] == "Ground Floor" and payload["keep_out"] == ["Exclusion Zone - Material Storage"]
    assert payload["open_doors"] == ["Door D01"] and payload["length_m"] > np.hypot(15.0, 9.0)
    for name in ("map.pgm", "map.yaml", "map_keepout.pgm", "map_keepout.yaml", "plan.png"):
        assert (tmp_path / name).is_file(), name


def test_plan_into_a_keepout_zone_is_a_one_line_error(site_model):
    result = run_cli("plan", str(site_model.path), "--from", "1,1", "--to", "16.5,3")
    assert result.returncode == 1 and "Traceback" not in result.stderr
    assert result.stderr.strip() == "error: goal (16.50, 3.00) is inside Exclusion Zone - Material Storage (keep-out zone)"


def test_plan_with_a_closed_door_or_a_bad_point(site_model):
    closed = run_cli("plan", str(site_model.path), "--from", "1,1", "--to", "16,10", "--doors", "Door D01")
    assert closed.returncode == 1 and "blocked by Door D01 (IfcDoor)" in closed.stderr
    bad = run_cli("plan", str(site_model.path), "--from", "1;1", "--to", "16,10")
    assert bad.returncode == 2 and "give a point as X,Y" in bad.stderr
    zero = run_cli("plan", str(site_model.path), "--resolution", "0")
    assert zero.returncode == 1 and "resolution must be a number of metres > 0 (got 0.0)" in zero.stderr


def test_bench_planning_runs_its_three_figures_in_one_run(site_model):
    result = run_cli("bench", "planning", "--file", str(site_model.path), "--repeat", "1", "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert set(report["times_s"]) == set(report["cpu_s"]) == {"load_cold", "grid_build", "section_floor", "plan_path", "pyastar2d", "replan",
                                      "rebuild_and_plan"}
    assert report["maze"]["cells"] == [1000, 1000] and report["path_target"] == 1.2
    assert report["maze"]["detour_m"] != report["maze"]["path_m"]  # the drum moved the path
    assert report["grid"]["storey"] == "Ground Floor" and report["path_ratio"] > 0
