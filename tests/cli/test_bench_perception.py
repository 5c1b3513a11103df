"""`bim2rdt bench perception` runs end to end on one seed."""

from __future__ import annotations

import json
import subprocess
import sys


def test_bench_perception_json_scores_both_detectors_and_checks_every_target(tmp_path):
    result = subprocess.run([sys.executable, "-m", "bim2rdt", "bench", "perception", "--seeds", "1",
                             "--flying-trials", "1", "--json", "--out", str(tmp_path)],
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    by_name = {d["detector"]: d for d in report["detectors"]}
    assert set(by_name) >= {"ideal", "geometric"} and report["frames"] == 10
    assert by_name["ideal"]["recall"] == 1.0 and by_name["ideal"]["family_accuracy"] == 1.0
    assert by_name["geometric"]["objects"] == by_name["ideal"]["objects"] > 0
    assert set(by_name["geometric"]["stage_seconds_median"]) == {"back-project", "background", "cluster", "name",
                                                                 "points+register"}
    assert [t[0] for t in report["targets"]] == ["recall", "precision", "family_accuracy", "translation_m_median",
                                                 "tilt_deg_median", "yaw_deg_median", "seconds_per_frame_median"]
    assert [row["condition"] for row in report["flying"]][:2] == ["clean depth", "flying pixels"]
    assert json.loads((tmp_path / "results.json").read_text())["seeds"] == [0]


def test_bench_perception_refuses_half_a_yoloe_setup(tmp_path):
    result = subprocess.run([sys.executable, "-m", "bim2rdt", "bench", "perception", "--yoloe-weights", "w.pt",
                             "--out", str(tmp_path)], capture_output=True, text=True, timeout=120)
    assert result.returncode != 0 and "go together" in result.stderr
