"""verify's thresholds are Settings sections: set from the environment, read by the code, recorded in the run's
config.json; verify localizes with ``Settings.localization`` (the real sensor's defaults where it sets nothing);
the perception section reaches the demo's detector."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from bim2rdt.config import ConfigError, get_settings


def test_verify_localizes_with_the_localization_section_and_real_sensor_defaults(monkeypatch):
    settings = get_settings()
    assert (settings.verify.localization.inlier_distance, settings.verify.localization.huber_delta,
            settings.verify.localization.min_inlier_fraction) == (0.05, 0.025, 0.3)
    assert settings.localization.inlier_distance != 0.05  # the robot's own default stays the robot's
    monkeypatch.setenv("BIM2RDT_LOCALIZATION__INLIER_DISTANCE", "0.04")
    monkeypatch.setenv("BIM2RDT_LOCALIZATION__MAX_RANGE", "6.5")
    monkeypatch.setenv("BIM2RDT_TWIN__MIN_FITNESS", "0.4")
    get_settings.cache_clear()
    settings = get_settings()
    assert settings.verify.localization.inlier_distance == 0.04  # what the user set wins
    assert settings.verify.localization.max_range == 6.5 and settings.verify.localization.huber_delta == 0.025
    assert settings.verify.min_fitness == 0.4


def test_verify_localization_is_set_in_one_place(monkeypatch):
    monkeypatch.setenv("BIM2RDT_VERIFY__LOCALIZATION__INLIER_DISTANCE", "0.04")
    get_settings.cache_clear()
    with pytest.raises(ConfigError, match="set BIM2RDT_LOCALIZATION__\\* only"):
        get_settings()


def test_verify_judges_with_the_one_judge_section_set_in_one_place(monkeypatch):
    monkeypatch.setenv("BIM2RDT_JUDGE__MIN_FIT_ON", "0.2")
    get_settings.cache_clear()
    assert get_settings().verify.judge.min_fit_on == 0.2  # verify judges as the mission does
    get_settings.cache_clear()
    monkeypatch.setenv("BIM2RDT_VERIFY__JUDGE__MIN_FIT_ON", "0.3")
    with pytest.raises(ConfigError, match="set BIM2RDT_JUDGE__\\* only"):
        get_settings()


def test_the_verify_and_perception_sections_come_from_the_environment(monkeypatch):
    monkeypatch.setenv("BIM2RDT_VERIFY__PLANNED__SEARCH", "0.7")
    monkeypatch.setenv("BIM2RDT_VERIFY__DEPTH__MAX_ANGLE_ERROR_DEG", "4")
    monkeypatch.setenv("BIM2RDT_PERCEPTION__GEOMETRIC__NAMING__MIN_FITNESS", "0.75")
    monkeypatch.setenv("BIM2RDT_PERCEPTION__PERCEIVE__FUSE_DISTANCE", "0.2")
    get_settings.cache_clear()
    settings = get_settings()
    assert settings.verify.planned.search == 0.7 and settings.verify.depth.max_angle_error_deg == 4.0
    assert settings.perception.geometric.naming.min_fitness == 0.75
    assert settings.perception.perceive.fuse_distance == 0.2
    monkeypatch.setenv("BIM2RDT_VERIFY__NEW__MIN_POINTS", "many")
    get_settings.cache_clear()
    with pytest.raises(ConfigError, match="^BIM2RDT_VERIFY__NEW__MIN_POINTS: "):
        get_settings()


def test_the_perception_section_reaches_the_geometric_detector(site_model):
    from bim2rdt.perception import GeometricConfig, GeometricDetector
    from bim2rdt.perception.detectors import make_detector

    config = GeometricConfig(stride=4)
    detector = make_detector("geometric", site_model, {}, geometric=config)
    assert isinstance(detector, GeometricDetector) and detector.config.stride == 4


def test_a_verify_setting_from_the_environment_changes_the_run_and_is_recorded(sensors, tmp_path, monkeypatch):
    """office1 finds 4 new objects by default (tests/cli/test_verify.py); with clusters needing a million points
    it finds none, and config.json says why."""
    from bim2rdt.cli import app

    truth = json.loads((sensors / "pcl" / "office1_truth.json").read_text())
    T = truth["T_world_camera"]
    import math

    yaw = math.degrees(math.atan2(T[1][2], T[0][2])) + 5.0
    prior = f"{T[0][3] + 0.14},{T[1][3] + 0.14},{T[2][3]},{yaw}"
    g = ",".join(str(x) for x in truth["depth_correction"]["g"])
    monkeypatch.setenv("BIM2RDT_VERIFY__NEW__MIN_POINTS", "1000000")
    get_settings.cache_clear()
    result = CliRunner().invoke(app, ["verify", str(sensors / "pcl" / "office1.ifc"), str(sensors / "pcl" /
                                      "office1.pcd"), "--out", str(tmp_path), "--json", "--prior", prior,
                                      "--depth-correction", g])
    assert result.exit_code == 0, result.output
    assert json.loads(result.output)["verdicts"]["new"] == 0
    record = json.loads((tmp_path / "config.json").read_text())
    assert record["settings"]["verify"]["new"]["min_points"] == 1_000_000
    assert record["settings"]["verify"]["localization"]["inlier_distance"] == 0.05
    assert record["prior"] is not None and record["detector"] == "cluster"
