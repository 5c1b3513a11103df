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


def test_the_missions_knobs_are_a_settings_section_read_from_the_environment(monkeypatch):
    from bim2rdt.mission import MissionConfig

    monkeypatch.setenv("BIM2RDT_MISSION__MOVED_TRANSLATION", "0.12")
    settings = get_settings()
    assert isinstance(settings.mission, MissionConfig) and settings.mission.moved_translation == 0.12
    assert settings.mission.standoff == MissionConfig().standoff


def test_a_misspelt_mission_setting_is_refused_naming_it(monkeypatch):
    monkeypatch.setenv("BIM2RDT_MISSION__MOVED_TRANSLATON", "0.12")
    with pytest.raises(ConfigError, match=r"^BIM2RDT_MISSION__MOVED_TRANSLATON: Extra inputs are not permitted"):
        get_settings()


def test_the_record_of_a_run_holds_every_section_and_masks_every_secret(monkeypatch):
    from bim2rdt.config import settings_record

    monkeypatch.setenv("BIM2RDT_LLM__API_KEY", "sk-live-123")
    monkeypatch.setenv("BIM2RDT_MQTT__PASSWORD", "hunter2")
    record = settings_record(get_settings())
    assert {"registration", "mission", "llm", "hav", "mqtt", "bim"} <= set(record)
    text = json.dumps(record)
    assert "sk-live-123" not in text and "hunter2" not in text and "change-me" not in text
    assert record["llm"]["api_key"] == "***" and record["llm"]["base_url"] is None  # unset stays visible
