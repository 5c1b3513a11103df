"""Secrets never leave in clear (issue 36, item 10): the password of a URL is masked in every setting, whatever its
name (``hav.store_url`` was printed by ``bim2rdt config`` and written into config.json), and a broker secret
shorter than ``MIN_SECRET_LENGTH`` is refused."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from pydantic import BaseModel

from bim2rdt.config import MIN_SECRET_LENGTH, ConfigError, Settings, get_settings, settings_record

SRC = str(Path(__file__).resolve().parents[1] / "src")


def _leaves(model: type[BaseModel], prefix: str = "BIM2RDT_") -> list[str]:
    """The environment variable of every setting (sections walked down to their fields)."""
    names = []
    for name, field in model.model_fields.items():
        variable = f"{prefix}{name.upper()}"
        kind = field.annotation
        if isinstance(kind, type) and issubclass(kind, BaseModel):
            names += _leaves(kind, variable + "__")
        else:
            names.append(variable)
    return names


def _url(variable: str) -> str:
    return f"postgresql+psycopg://user:pw-{variable.lower()}-hunter2@db.example:5432/site"


@pytest.fixture
def every_url_setting(monkeypatch):
    """{variable: URL with a password} for every setting that accepts one (the others refuse it when loaded)."""
    for key in [k for k in os.environ if k.startswith("BIM2RDT_")]:
        monkeypatch.delenv(key)
    accepted = {}
    for variable in _leaves(Settings):
        with monkeypatch.context() as patch:
            patch.setenv(variable, _url(variable))
            get_settings.cache_clear()
            try:
                get_settings()
            except ConfigError:
                continue
            accepted[variable] = _url(variable)
    get_settings.cache_clear()
    yield accepted
    get_settings.cache_clear()


def test_every_setting_that_takes_a_url_has_its_password_masked_in_a_runs_record(monkeypatch, every_url_setting):
    assert {"BIM2RDT_HAV__STORE_URL", "BIM2RDT_TWIN__URL"} <= set(every_url_setting)
    assert len(every_url_setting) >= 10  # the string settings: paths, models, hosts ... take one too
    for variable, url in every_url_setting.items():
        monkeypatch.setenv(variable, url)
    get_settings.cache_clear()
    text = json.dumps(settings_record(get_settings()))
    assert "hunter2" not in text
    assert "postgresql+psycopg://user:***@db.example:5432/site" in text


@pytest.mark.parametrize("as_json", [True, False])
def test_bim2rdt_config_masks_every_url_password(every_url_setting, as_json):
    env = {key: value for key, value in os.environ.items() if not key.startswith("BIM2RDT_")}
    done = subprocess.run([sys.executable, "-m", "bim2rdt", "config", *(["--json"] if as_json else [])],
                          capture_output=True, text=True, timeout=120,
                          env={**env, "PYTHONPATH": SRC, "COLUMNS": "400", **every_url_setting})
    assert done.returncode == 0, done.stderr
    assert "hunter2" not in done.stdout and "user:***@" in done.stdout
    if as_json:
        assert json.loads(done.stdout)["BIM2RDT_HAV__STORE_URL"]["value"].startswith("postgresql+psycopg://user:***@")


def test_a_password_holding_at_signs_is_masked_whole():
    from bim2rdt.config import _masked

    assert _masked({"url": "nats://w1:p@ss:w@rd@host:4222"}) == {"url": "nats://w1:***@host:4222"}


@pytest.mark.parametrize("variable", ["BIM2RDT_MQTT__PASSWORD", "BIM2RDT_MQTT__DEVICE_SECRET",
                                      "BIM2RDT_HAV__SITE_SECRET"])
def test_a_broker_secret_shorter_than_the_minimum_is_refused_naming_it(monkeypatch, variable):
    monkeypatch.setenv(variable, "x" * (MIN_SECRET_LENGTH - 1))
    get_settings.cache_clear()
    try:
        with pytest.raises(ConfigError, match=rf"^{variable}: String should have at least {MIN_SECRET_LENGTH}"):
            get_settings()
        monkeypatch.setenv(variable, "x" * MIN_SECRET_LENGTH)
        get_settings.cache_clear()
        get_settings()
    finally:
        get_settings.cache_clear()
