"""The monitor's configuration is one object: MonitorConfig, also Settings.hav (BIM2RDT_HAV__*)."""

from __future__ import annotations

import pytest

from bim2rdt.config import ConfigError, Settings, get_settings
from bim2rdt.safety import MonitorConfig
from bim2rdt.cli.hav_output import open_monitor


def test_the_hav_settings_are_the_monitor_config_and_repeat_no_default():
    assert Settings().hav.monitor_config() == MonitorConfig()
    assert "site_secret" not in MonitorConfig.model_fields  # the secret is the monitor's own argument


def test_an_environment_value_reaches_the_monitor_that_runs(monkeypatch, tmp_path):
    monkeypatch.setenv("BIM2RDT_HAV__MAX_REORDER", "3")
    monkeypatch.setenv("BIM2RDT_MQTT__SITE", "north")
    monitor = open_monitor(get_settings(), data_dir=tmp_path)
    assert monitor.config.max_reorder == 3 and monitor.config.site == "north"
    assert get_settings().hav.monitor_config(keep_timeline=True).keep_timeline is True
    monitor.close()


def test_the_monitor_site_follows_the_bus_site_and_a_different_one_is_refused(monkeypatch):
    monkeypatch.setenv("BIM2RDT_MQTT__SITE", "north")
    assert get_settings().hav.site == "north"
    get_settings.cache_clear()
    monkeypatch.setenv("BIM2RDT_HAV__SITE", "south")
    with pytest.raises(ConfigError, match="BIM2RDT_MQTT__SITE only"):
        get_settings()


def test_a_runs_record_holds_the_hav_section_with_its_secret_masked(monkeypatch):
    from bim2rdt.config import settings_record

    monkeypatch.setenv("BIM2RDT_HAV__START_THRESHOLD", "1.5")
    monkeypatch.setenv("BIM2RDT_HAV__SITE_SECRET", "a-real-secret")
    record = settings_record(get_settings())
    assert record["hav"]["start_threshold"] == 1.5 and record["hav"]["site"] == record["mqtt"]["site"]
    assert record["hav"]["site_secret"] == "***" and "a-real-secret" not in str(record)


@pytest.mark.parametrize("variable, value, message", [
    ("BIM2RDT_HAV__START_THRESHOLD", "nan", "finite number"), ("BIM2RDT_HAV__MAX_REORDER", "-5", "greater than"),
    ("BIM2RDT_HAV__SITE_SECRET", "", "at least 8 characters"), ("BIM2RDT_HAV__STOP_THRESHOLD", "3", "stop_threshold"),
    ("BIM2RDT_MQTT__SITE", "a/#", "pattern"), ("BIM2RDT_MQTT__PASSWORD", "", "at least 8 characters")])
def test_a_hav_setting_out_of_range_is_a_config_error_naming_it(monkeypatch, variable, value, message):
    monkeypatch.setenv(variable, value)
    with pytest.raises(ConfigError, match=message):
        get_settings()


def test_the_cli_refuses_a_nan_threshold_in_one_line(tmp_path):
    import subprocess
    import sys

    result = subprocess.run([sys.executable, "-m", "bim2rdt", "sim", "wearables", "--dev", "--minutes", "1"],
                            capture_output=True, text=True, timeout=120,
                            env={**__import__("os").environ, "BIM2RDT_HAV__START_THRESHOLD": "nan",
                                 "BIM2RDT_DATA_DIR": str(tmp_path)})
    assert result.returncode == 1
    assert result.stderr.strip().splitlines() == ["error: BIM2RDT_HAV__START_THRESHOLD: Input should be a finite "
                                                  "number (got 'nan')"]
