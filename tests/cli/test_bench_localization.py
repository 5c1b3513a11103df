"""`bim2rdt bench localization` runs end to end on a short tour, with Open3D as the peer."""

from __future__ import annotations

import json
import subprocess
import sys


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "bim2rdt", *args], capture_output=True, text=True, timeout=600)


def test_bench_localization_json_scores_every_station_against_dead_reckoning_and_the_peer(tmp_path):
    result = run_cli("bench", "localization", "--distance", "15", "--tolerance", "0", "--json", "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    stations = report["stations"]
    assert len(stations) >= 3 and stations[-1]["walked"] >= 15.0
    assert report["peers"] == ["Open3D pt-plane", "Open3D pt-plane, visible BIM"]
    assert all(set(s["peers"]) == set(report["peers"]) for s in stations)
    last = stations[-1]
    assert last["fused"]["position"] < 0.01 < 0.05 < last["dead_reckoning"]["position"]  # building as modelled
    assert all(s["fix"] is not None and s["fix_seconds"] > 0 for s in stations)
    names = [t["name"] for t in report["targets"]]
    assert "fused worst station <= 5 cm" in names and "<= 0.3 s per frame on one core" in names
    assert (tmp_path / "errors.png").stat().st_size > 0
    assert json.loads((tmp_path / "results.json").read_text())["seed"] == 0


def test_bench_localization_prints_errors_against_distance_and_the_targets(tmp_path):
    result = run_cli("bench", "localization", "--distance", "10", "--no-peers", "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    assert "against distance walked" in result.stdout and "dead reckoning" in result.stdout
    verdicts = [line for line in result.stdout.splitlines() if " PASS " in line or " FAIL " in line]
    assert len(verdicts) == 4  # without peers: the four targets


def test_bench_localization_rejects_a_tour_too_short_to_walk(tmp_path):
    result = run_cli("bench", "localization", "--distance", "1", "--out", str(tmp_path))
    assert result.returncode == 2 and "--distance" in result.stderr
