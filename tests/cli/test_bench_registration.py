"""`bim2rdt bench registration` runs end to end on a tiny trial count."""

from __future__ import annotations

import json
import os
import subprocess
import sys


def run_cli(*args: str, **env: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "bim2rdt", *args], capture_output=True, text=True, timeout=300,
                          env={**os.environ, **env})


def test_bench_registration_json_has_every_scenario_method_and_target(tmp_path):
    result = run_cli("bench", "registration", "--trials", "1", "--json", "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert set(report["scenarios"]) == {"S1", "S2", "S3", "S4"}
    methods = report["scenarios"]["S1"]["methods"]
    assert {"ICP", "SG-ICP", "Open3D pt-pt", "Open3D pt-plane", "small_gicp plane 1T", "small_gicp GICP 1T",
            "small_gicp plane allT", "small_gicp GICP allT"} <= set(methods)
    assert all(0.0 <= m["success"] <= 1.0 and m["rmse"] > 0.0 for m in methods.values())
    assert all(sum(m["modes"].values()) == m["registrations"] for m in methods.values())
    assert all(m["knocked_tilt_deg"] is None or m["knocked_tilt_deg"] >= 0.0 for m in methods.values())
    # S1-S4's four, SG-ICP <= 0.5x small_gicp, S4 success, the families' two, the aliases' two, small_gicp's
    # accuracy, the covariance calibration
    assert len(report["targets"]) == 12
    assert set(report["families"]) == {f"F{i}" for i in range(1, 12)}
    assert {"ICP", "SG-ICP", "Open3D pt-plane", "small_gicp plane 1T", "small_gicp GICP 1T"} == set(
        report["families"]["F1"]["methods"])
    assert "alias_agreement" in report["families"]["F10"] and "alias_agreement" not in report["families"]["F1"]
    assert 0.0 <= report["families"]["F11"]["alias_agreement"]["share"] <= 1.0
    assert report["speed"]["sg_icp_ratio"]["small_gicp plane 1T"] > 0.0
    assert report["worst_family"] in report["families"]
    assert report["priors"]["Survey_Tripod_Aluminium"]["upright_bias"] < report["priors"][
        "Wooden_Crate_1200x800x600"]["upright_bias"]
    assert sorted(p.name for p in tmp_path.glob("*.png")) == [f"registration_S{i}.png" for i in range(1, 5)]
    assert json.loads((tmp_path / "results.json").read_text())["trials"] == 1


def test_bench_registration_prints_the_table_with_pass_or_fail(tmp_path):
    result = run_cli("bench", "registration", "--trials", "1", "--no-peers", "--out", str(tmp_path),
                     BIM2RDT_REGISTRATION__RESTARTS="12")
    assert result.returncode == 0, result.stderr
    assert "SG-ICP" in result.stdout and "Targets" in result.stdout
    assert "fails t/f/y/s" in result.stdout and "leaning tilt" in result.stdout
    verdicts = [line for line in result.stdout.splitlines() if " PASS " in line or " FAIL " in line]
    assert len(verdicts) == 8  # no peers: RMSE cut, no worse than ICP, S4 success, the families' and aliases' two
    # each, calibration
    assert "covariance: in 95 %" in result.stdout
    assert "worst family" in result.stdout and "Scene families" in result.stdout
    results = json.loads((tmp_path / "results.json").read_text())
    assert results["config"]["restarts"] == 12  # what the methods ran with ...
    assert results["settings"]["registration"]["restarts"] == 12  # ... is what the record shows


def test_bench_registration_can_leave_the_families_out(tmp_path):
    result = run_cli("bench", "registration", "--trials", "1", "--no-peers", "--no-families", "--json",
                     "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["families"] == {} and report["worst_family"] is None and len(report["targets"]) == 4


def test_bench_registration_rejects_zero_trials(tmp_path):
    result = run_cli("bench", "registration", "--trials", "0", "--out", str(tmp_path))
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert "'--trials'" in result.stderr and not list(tmp_path.iterdir())


def test_bench_registration_runs_only_the_scenarios_asked_for(tmp_path):
    result = run_cli("bench", "registration", "--trials", "1", "--no-peers", "--no-families", "--json",
                     "--scenario", "S2", "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert set(report["scenarios"]) == {"S2"}
    assert sorted(p.name for p in tmp_path.glob("*.png")) == ["registration_S2.png"]


def test_bench_registration_rejects_an_unknown_scenario(tmp_path):
    out = tmp_path / "run"
    result = run_cli("bench", "registration", "--scenario", "S9", "--out", str(out))
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert "unknown scenario S9" in result.stderr and not out.exists()
