"""`bim2rdt bench localization` runs end to end on a short tour, with Open3D as the peer."""

from __future__ import annotations

import json
import subprocess
import sys


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "bim2rdt", *args], capture_output=True, text=True, timeout=600)


def test_bench_localization_json_scores_every_station_against_dead_reckoning_and_the_peer(tmp_path):
    result = run_cli("bench", "localization", "--distance", "15", "--tolerance", "0", "--no-office", "--json",
                     "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    stations = report["stations"]
    assert len(stations) >= 3 and stations[-1]["walked"] >= 15.0
    assert report["peers"] == ["Open3D pt-plane", "Open3D pt-plane, visible BIM"]
    assert all(set(s["peers"]) == set(report["peers"]) for s in stations)
    last = stations[-1]
    assert last["fused"]["position"] < 0.01 < 0.05 < last["dead_reckoning"]["position"]  # building as modelled
    assert all(s["fix"] is not None and s["fix_seconds"] > 0 for s in stations)
    assert all(len(s["frame_seconds"]) == s["looks"] and s["fix_seconds"] == max(s["frame_seconds"]) for s in stations)
    assert report["summary"]["bim"]["worst_seconds"] == max(t for s in stations for t in s["frame_seconds"])
    names = [t["name"] for t in report["targets"]]
    assert "fused worst station <= 5 cm" in names and "<= 0.3 s per frame on one core" in names
    assert (tmp_path / "errors.png").stat().st_size > 0
    assert json.loads((tmp_path / "results.json").read_text())["seed"] == 0


def test_bench_localization_prints_errors_against_distance_and_the_targets(tmp_path):
    result = run_cli("bench", "localization", "--distance", "10", "--no-peers", "--no-office", "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    assert "against distance walked" in result.stdout and "dead reckoning" in result.stdout
    verdicts = [line for line in result.stdout.splitlines() if " PASS " in line or " FAIL " in line]
    assert len(verdicts) == 4  # without peers: the four targets


def test_bench_localization_rejects_a_tour_too_short_to_walk(tmp_path):
    result = run_cli("bench", "localization", "--distance", "1", "--out", str(tmp_path))
    assert result.returncode == 2 and "--distance" in result.stderr


def test_bench_localization_fixes_the_real_office_frame_from_twenty_priors(tmp_path, sensors):
    result = run_cli("bench", "localization", "--no-tour", "--sensors", str(sensors), "--json", "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    office = json.loads(result.stdout)["office"]
    assert office["frame"] == "pcl/office1.pcd" and office["priors"] == 20
    for name in ("corrected", "raw"):
        variant = office["variants"][name]
        assert len(variant["fixes"]) == 20
        summary = variant["summary"]
        assert summary["accepted"] + summary["refused"] == 20 == sum(summary["refusals"].values()) + summary["accepted"]
        for fix in variant["fixes"]:
            assert fix["prior_position_cm"] <= 30.0 + 1e-9 and abs(fix["prior_yaw_deg"]) <= 8.0 + 1e-9
            assert (fix["position_cm"] is None) == (fix["reason"] is not None) and fix["seconds"] > 0
    assert json.loads((tmp_path / "results.json").read_text())["office"]["variants"].keys() == {"corrected", "raw"}


def test_the_office_table_names_each_depth_variant_and_its_refusals(capsys):
    from bim2rdt.cli.localization import show_office

    summary = {"accepted": 18, "refused": 2, "refusals": {"moved beyond the basin": 2}, "median_position_cm": 1.5,
               "worst_position_cm": 2.5, "median_yaw_deg": 0.2, "worst_yaw_deg": 0.6, "median_prior_cm": 20.0,
               "median_seconds": 0.1}
    show_office({"frame": "pcl/office1.pcd", "priors": 20, "radius_m": 0.3, "yaw_deg": 8.0,
                 "variants": {"corrected": {"summary": summary}, "raw": {"summary": {**summary, "accepted": 0}}}})
    out = capsys.readouterr().out
    assert "Real office frame (pcl/office1.pcd)" in out and "18/20" in out and "median 1.50 cm / 0.20 deg" in out
    assert "2 moved beyond the basin" in out and "0/20" in out


def test_bench_localization_says_when_the_office_frame_is_absent(tmp_path):
    result = run_cli("bench", "localization", "--no-tour", "--sensors", str(tmp_path / "none"), "--json",
                     "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    assert "no pcl/office1.pcd under" in json.loads(result.stdout)["office"]["skipped"]
