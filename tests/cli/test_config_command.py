"""`bim2rdt config`: the resolved settings, each with its variable and whether the environment set it."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from bim2rdt.cli.config import setting_rows

SRC = str(Path(__file__).resolve().parents[2] / "src")


def run_config(*args: str, **environment: str) -> subprocess.CompletedProcess:
    import os

    env = {key: value for key, value in os.environ.items() if not key.startswith("BIM2RDT_")}
    return subprocess.run([sys.executable, "-m", "bim2rdt", "config", *args], capture_output=True, text=True,
                          env={**env, "PYTHONPATH": SRC, **environment}, timeout=120)


def test_a_setting_from_the_environment_is_shown_with_its_value_and_origin():
    done = run_config("--changed", "--json", BIM2RDT_REGISTRATION__RESTARTS="8")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout) == {"BIM2RDT_REGISTRATION__RESTARTS": {"value": 8, "from": "environment"}}


def test_a_section_given_as_one_json_variable_marks_each_of_its_fields_as_from_the_environment():
    rows = setting_rows({"mqtt": {"port": 1884, "site": "demo"}, "data_dir": "var"}, {"BIM2RDT_MQTT": "{}"})
    assert rows == [("BIM2RDT_MQTT__PORT", 1884, "environment"), ("BIM2RDT_MQTT__SITE", "demo", "environment"),
                    ("BIM2RDT_DATA_DIR", "var", "default")]


def test_secrets_are_masked_and_an_unknown_section_is_one_line():
    done = run_config("hav", "--json", BIM2RDT_HAV__SITE_SECRET="s3cret-value")
    assert done.returncode == 0, done.stderr
    shown = json.loads(done.stdout)
    assert shown["BIM2RDT_HAV__SITE_SECRET"] == {"value": "***", "from": "environment"}
    assert "s3cret-value" not in done.stdout
    bad = run_config("nope")
    assert bad.returncode == 2 and "no section 'nope'" in bad.stderr and "Traceback" not in bad.stderr


def test_a_bad_value_is_one_line_naming_the_variable():
    done = run_config(BIM2RDT_MQTT__PORT="not-a-port")
    assert done.returncode == 1 and "BIM2RDT_MQTT__PORT" in done.stderr and "Traceback" not in done.stderr
