"""The demo's settings: the environment's, with the demo's raw retention where the environment sets none."""

from __future__ import annotations

import pytest

from bim2rdt.config import Settings
from bim2rdt.demo.settings import DEMO_RAW_RETENTION_S, demo_settings


def test_the_demo_keeps_no_raw_batches_unless_the_environment_says_how_long():
    settings = Settings()
    ran = demo_settings(settings)
    assert ran.hav.raw_retention_s == DEMO_RAW_RETENTION_S == 0.0
    assert settings.hav.raw_retention_s == 7 * 86400  # the monitor's own default is untouched
    assert ran.model_dump(exclude={"hav"}) == settings.model_dump(exclude={"hav"})
    assert ran.hav.model_dump(exclude={"raw_retention_s"}) == settings.hav.model_dump(exclude={"raw_retention_s"})


@pytest.mark.parametrize("variable, value", [("BIM2RDT_HAV__RAW_RETENTION_S", "604800"),
                                             ("BIM2RDT_HAV", '{"raw_retention_s": 900}')])
def test_a_retention_set_in_the_environment_is_the_one_the_demo_runs_with(monkeypatch, variable, value):
    monkeypatch.setenv(variable, value)
    settings = Settings()
    assert demo_settings(settings) is settings
    assert settings.hav.raw_retention_s in (604800.0, 900.0)
