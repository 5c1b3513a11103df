"""`bim2rdt bench localization` runs end to end on a short tour, with Open3D as the peer."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "bim2rdt", *args], capture_output=True, text=True, timeout=600)


def test_bench_localization_json_scores_every_station_against_dead_reckoning_and_the_peer(tmp_path):
    result = run_cli("bench", "localization", "--distance", "15", "--tolerance", "0", "--no-office", "--no-global",
                     "--json", "--out", str(tmp_path))
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
    result = run_cli("bench", "localization", "--distance", "10", "--no-peers", "--no-office", "--no-global", "--out",
                     str(tmp_path))
    assert result.returncode == 0, result.stderr
    assert "against distance walked" in result.stdout and "dead reckoning" in result.stdout
    verdicts = [line for line in result.stdout.splitlines() if " PASS " in line or " FAIL " in line]
    assert len(verdicts) == 4  # without peers: the four targets


def test_the_global_section_searches_every_station_with_no_prior_and_runs_fpfh_ransac_on_the_same_frames(tmp_path):
    result = run_cli("bench", "localization", "--distance", "5", "--no-office", "--json", "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)["global"]
    stations = report["stations"]
    assert len(stations) == len(json.loads(result.stdout)["stations"]) >= 2
    assert {s["outcome"] for s in stations} <= {"success", "wrong", "refused"}
    assert all(s["seconds"] > 0 and s["peer"]["seconds"] > 0 for s in stations)
    ours = report["summary"]["ours"]
    assert ours["wrong_and_confident_rate"] == 0.0  # never a confident wrong pose
    assert ours["success_rate"] == sum(s["outcome"] == "success" for s in stations) / len(stations) > 0
    assert stations[1]["outcome"] == "success" and stations[1]["position_m"] < 0.05  # the unique view
    assert stations[0]["outcome"] == "refused" and stations[0]["reason"].startswith("ambiguous")  # a corner
    assert report["summary"]["peer"]["stations"] == len(stations)
    assert report["summary"]["look_around"]["wrong_and_confident_rate"] == 0.0
    assert all(s["look_around"]["seconds"] > 0 for s in stations)
    sweep = report["summary"]["sweep"]  # the stations in order, on the robot's drifting, unaligned odometry
    assert sweep["stations"] == len(stations) and sweep["wrong_and_confident_rate"] == 0.0
    assert stations[0]["sweep"]["outcome"] == "success" and stations[0]["sweep"]["how"] == "backfill"  # the corner
    assert stations[0]["sweep"]["resolved_at"] == 1 and stations[0]["sweep"]["position_m"] < 0.05
    assert stations[1]["sweep"]["how"] == "carried" and stations[1]["sweep"]["outcome"] == "success"
    assert sweep["success_rate"] == 1.0 and all(s["sweep"]["seconds"] > 0 for s in stations)
    people = report["people"]["summary"]  # frames looking at the site's people, each searched alone
    assert people["person_in_view"] >= 20 and people["with"]["wrong"] == 0
    assert people["without"]["wrong"] >= 1  # the turned corner: every point on its own, a place 13.5 m off is taken
    assert people["with"]["success"] == people["without"]["success"] > 0


def test_bench_localization_rejects_a_tour_too_short_to_walk(tmp_path):
    result = run_cli("bench", "localization", "--distance", "1", "--out", str(tmp_path))
    assert result.returncode == 2 and "--distance" in result.stderr


@pytest.fixture(scope="module")
def office_run(tmp_path_factory, sensors) -> tuple[dict, Path]:
    """The office frame alone, from 3 priors (the bench's default is 20): its JSON and its --out folder."""
    out = tmp_path_factory.mktemp("office")
    result = run_cli("bench", "localization", "--no-tour", "--sensors", str(sensors), "--office-priors", "3", "--json",
                     "--out", str(out))
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)["office"], out


def test_bench_localization_fixes_the_real_office_frame_from_priors_around_its_truth(office_run):
    office, out = office_run
    assert office["frame"] == "pcl/office1.pcd" and office["priors"] == 3
    for variant in [*office["variants"].values(), office["cloud"]]:
        assert len(variant["fixes"]) == 3
        summary = variant["summary"]
        assert summary["accepted"] + summary["refused"] == 3 == sum(summary["refusals"].values()) + summary["accepted"]
        for fix in variant["fixes"]:
            assert fix["prior_position_cm"] <= 30.0 + 1e-9 and abs(fix["prior_yaw_deg"]) <= 8.0 + 1e-9
            assert (fix["position_cm"] is None) == (fix["reason"] is not None) == (fix["pose"] is None)
            assert fix["seconds"] > 0
    stored = json.loads((out / "results.json").read_text())["office"]
    assert stored["variants"].keys() == {"corrected", "raw"} and stored["cloud"]["localizer"] == "localize_cloud"


def test_the_cloud_localizer_fixes_the_office_frame_within_3_cm_and_1_degree(office_run, sensors):
    truth = json.loads((sensors / "pcl" / "office1_truth.json").read_text())
    T_true = np.array(truth["T_world_camera"])
    cloud = office_run[0]["cloud"]
    basin_m, basin_deg = cloud["config"]["max_correction"], cloud["config"]["max_correction_deg"]
    assert cloud["config"]["inlier_distance"] == 0.05 and cloud["config"]["min_inlier_fraction"] == 0.3  # verify's
    fixed = 0
    for fix in cloud["fixes"]:
        if fix["pose"] is None:  # only a prior beyond verify's basin (8 deg priors, 6 deg basin) may be refused
            assert abs(fix["prior_yaw_deg"]) > basin_deg or fix["prior_position_cm"] > basin_m * 100, fix["reason"]
            continue
        pose = np.array(fix["pose"])
        assert np.linalg.norm(pose[:3, 3] - T_true[:3, 3]) < 0.03
        assert _heading_deg(pose, T_true) < 1.0
        fixed += 1
    assert fixed >= 2


def _heading_deg(T_a: np.ndarray, T_b: np.ndarray) -> float:
    """Angle between the two cameras' viewing directions (optical z) projected on the floor, degrees."""
    a, b = T_a[:2, 2], T_b[:2, 2]
    turn = np.arctan2(a[0] * b[1] - a[1] * b[0], a @ b)
    return float(abs(np.rad2deg(turn)))


def test_the_office_table_names_each_depth_variant_and_its_refusals(capsys):
    from bim2rdt.cli.localization import show_office

    summary = {"accepted": 18, "refused": 2, "refusals": {"moved beyond the basin": 2}, "median_position_cm": 1.5,
               "worst_position_cm": 2.5, "median_yaw_deg": 0.2, "worst_yaw_deg": 0.6, "median_prior_cm": 20.0,
               "median_seconds": 0.1}
    show_office({"frame": "pcl/office1.pcd", "priors": 20, "radius_m": 0.3, "yaw_deg": 8.0,
                 "variants": {"corrected": {"summary": summary}, "raw": {"summary": {**summary, "accepted": 0}}},
                 "cloud": {"depth": "corrected", "summary": {**summary, "accepted": 20, "refused": 0, "refusals": {},
                                                             "median_position_cm": 0.61}}})
    out = capsys.readouterr().out
    assert "Real office frame (pcl/office1.pcd)" in out and "18/20" in out and "median 1.50 cm / 0.20 deg" in out
    assert "2 moved beyond the basin" in out and "0/20" in out
    assert "localize_cloud, corrected" in out and "20/20" in out and "median 0.61 cm" in out


def test_bench_localization_says_when_the_office_frame_is_absent(tmp_path):
    result = run_cli("bench", "localization", "--no-tour", "--sensors", str(tmp_path / "none"), "--json",
                     "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    assert "no pcl/office1.pcd under" in json.loads(result.stdout)["office"]["skipped"]
