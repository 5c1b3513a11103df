"""Settings from the environment: a bad value is a one-line typed error naming the variable, not a traceback."""

from __future__ import annotations

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
