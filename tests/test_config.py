"""Settings from the environment: a bad value is a one-line typed error naming the variable, not a traceback."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from bim2rdt.config import ConfigError, get_settings


def test_a_bad_environment_value_raises_a_config_error_naming_the_variable(monkeypatch):
    monkeypatch.setenv("BIM2RDT_REGISTRATION__RESTARTS", "0")
    with pytest.raises(ConfigError, match=r"^BIM2RDT_REGISTRATION__RESTARTS: .*greater than or equal to 1"):
        get_settings()


def test_the_cli_reports_a_bad_environment_value_in_one_line_and_exits_1(tmp_path, monkeypatch):
    monkeypatch.setenv("BIM2RDT_REGISTRATION__RESTARTS", "zero")
    result = subprocess.run([sys.executable, "-m", "bim2rdt", "bench", "registration", "--trials", "1",
                             "--no-peers", "--out", str(tmp_path)], capture_output=True, text=True, timeout=120)
    assert result.returncode == 1
    assert result.stderr.strip().splitlines() == [
        "error: BIM2RDT_REGISTRATION__RESTARTS: Input should be a valid integer, unable to parse string as an "
        "integer (got 'zero')"]


@pytest.fixture(scope="module")
def site_ifc_path(tmp_path_factory):
    from bim2rdt.sim.site import build_site_ifc

    return build_site_ifc(tmp_path_factory.mktemp("site") / "site.ifc")


def _cli(*args: str, **env: str) -> subprocess.CompletedProcess:
    import os

    return subprocess.run([sys.executable, "-m", "bim2rdt", *args], capture_output=True, text=True, timeout=300,
                          env={**os.environ, **env})


def test_a_whole_section_given_as_bad_json_is_one_line_naming_the_variable(site_ifc_path):
    result = _cli("info", str(site_ifc_path), BIM2RDT_MQTT="{bad")
    assert result.returncode == 1
    assert result.stderr.startswith("error: BIM2RDT_MQTT: not valid JSON (") and result.stderr.count("\n") == 1


def test_a_bad_field_inside_a_json_section_names_the_variable_that_was_set(monkeypatch):
    monkeypatch.setenv("BIM2RDT_MQTT", '{"port": "x"}')
    with pytest.raises(ConfigError, match=r"^BIM2RDT_MQTT \(field port\): Input should be a valid integer"):
        get_settings()


@pytest.mark.parametrize("variable", ["BIM2RDT_DATA_DIR", "BIM2RDT_CACHE_DIR"])
def test_a_folder_setting_that_names_a_file_is_refused(tmp_path, monkeypatch, variable):
    (tmp_path / "a_file").write_text("not a folder")
    monkeypatch.setenv(variable, str(tmp_path / "a_file"))
    with pytest.raises(ConfigError, match=rf"^{variable}: .*a_file is a file, not a folder$"):
        get_settings()


@pytest.mark.parametrize("cache", ["{tmp}/a_file/below", "/proc/bim2rdt-cache"], ids=["under a file", "in /proc"])
def test_an_unusable_cache_dir_is_one_line_before_the_model_is_read(site_ifc_path, tmp_path, cache):
    (tmp_path / "a_file").write_text("not a folder")
    result = _cli("info", str(site_ifc_path), BIM2RDT_CACHE_DIR=cache.format(tmp=tmp_path))
    assert result.returncode == 1 and result.stderr.count("\n") == 1
    assert result.stderr.startswith("error: BIM2RDT_CACHE_DIR: cannot write into ")


@pytest.mark.parametrize("data", ["{tmp}/a_file/below", "/proc/bim2rdt-data"], ids=["under a file", "in /proc"])
def test_an_unusable_data_dir_names_the_variable_before_the_hav_run(tmp_path, data):
    (tmp_path / "a_file").write_text("not a folder")
    result = _cli("sim", "wearables", "--dev", "--workers", "1", "--minutes", "1",
                  BIM2RDT_DATA_DIR=data.format(tmp=tmp_path))
    assert result.returncode == 1 and result.stderr.count("\n") == 1, result.stderr
    assert result.stderr.startswith("error: BIM2RDT_DATA_DIR: cannot write into ")
    assert "activity_started" not in result.stdout


def test_usable_folder_creates_the_folder_and_leaves_nothing_in_it(tmp_path):
    from bim2rdt.config import usable_folder

    assert usable_folder(tmp_path / "a" / "b", "BIM2RDT_X") == tmp_path / "a" / "b"
    assert list((tmp_path / "a" / "b").iterdir()) == []


def test_the_missions_knobs_are_a_settings_section_read_from_the_environment(monkeypatch):
    from bim2rdt.mission import MissionConfig

    monkeypatch.setenv("BIM2RDT_MISSION__MERGE_DISTANCE", "0.12")
    settings = get_settings()
    assert isinstance(settings.mission, MissionConfig) and settings.mission.merge_distance == 0.12
    assert settings.mission.standoff == MissionConfig().standoff


def test_a_misspelt_mission_setting_is_refused_naming_it(monkeypatch):
    monkeypatch.setenv("BIM2RDT_MISSION__MERGE_DISTANSE", "0.12")
    with pytest.raises(ConfigError, match=r"^BIM2RDT_MISSION__MERGE_DISTANSE: Extra inputs are not permitted"):
        get_settings()


def test_the_record_of_a_run_holds_every_section_and_masks_every_secret(monkeypatch):
    from bim2rdt.config import settings_record

    monkeypatch.setenv("BIM2RDT_LLM__API_KEY", "sk-live-123")
    monkeypatch.setenv("BIM2RDT_MQTT__PASSWORD", "hunter2-hunter2")
    record = settings_record(get_settings())
    assert {"registration", "mission", "llm", "hav", "mqtt", "bim"} <= set(record)
    text = json.dumps(record)
    assert "sk-live-123" not in text and "hunter2" not in text and "change-me" not in text
    assert record["llm"]["api_key"] == "***" and record["llm"]["base_url"] is None  # unset stays visible
