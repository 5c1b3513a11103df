"""Tolerance presets: by family, else by IFC class, else the default; built from the settings."""

from __future__ import annotations

import pytest

from bim2rdt.config import ConfigError, get_settings
from bim2rdt.twin import Tolerance, TolerancePolicy, TwinConfig, TwinError


def test_the_default_presets_are_loose_for_site_objects_and_tight_for_structure():
    policy = TwinConfig().tolerance_policy()
    cone = policy.for_element("IfcBuildingElementProxy", "Traffic_Cone_Orange_70cm")
    assert cone == Tolerance("temporary", 0.05, 5.0)
    assert policy.for_element("IfcColumn", "Concrete Column 400x400") == Tolerance("structural", 0.01, 0.5)
    assert policy.for_element("IfcWall", None).name == "structural"
    assert policy.for_element("IfcFurniture", None).name == "temporary"


def test_a_family_entry_wins_over_its_class():
    presets = {"loose": Tolerance("loose", 0.1, 10.0), "tight": Tolerance("tight", 0.01, 0.5)}
    policy = TolerancePolicy(presets, classes={"IfcBuildingElementProxy": "loose"},
                             families={"Steel_I-Beam_W12x26_A992": "tight"}, default="loose")
    assert policy.for_element("IfcBuildingElementProxy", "Steel_I-Beam_W12x26_A992").name == "tight"
    assert policy.for_element("IfcBuildingElementProxy", "Pallet_Wood_EUR").name == "loose"


def test_a_policy_naming_an_undefined_preset_is_refused():
    with pytest.raises(TwinError, match="nowhere"):
        TolerancePolicy({"a": Tolerance("a", 0.1, 1.0)}, classes={"IfcWall": "nowhere"}, default="a")


def test_presets_come_from_the_environment(monkeypatch):
    monkeypatch.setenv("BIM2RDT_TWIN__PRESETS", '{"site": {"translation": 0.2, "rotation_deg": 12}}')
    monkeypatch.setenv("BIM2RDT_TWIN__CLASSES", "{}")
    monkeypatch.setenv("BIM2RDT_TWIN__DEFAULT_PRESET", "site")
    get_settings.cache_clear()
    policy = get_settings().twin.tolerance_policy()
    assert policy.for_element("IfcColumn", None) == Tolerance("site", 0.2, 12.0)


def test_a_setting_naming_an_undefined_preset_is_a_one_line_config_error(monkeypatch):
    monkeypatch.setenv("BIM2RDT_TWIN__DEFAULT_PRESET", "lax")
    get_settings.cache_clear()
    with pytest.raises(ConfigError, match="BIM2RDT_TWIN.*lax") as caught:
        get_settings()
    assert "\n" not in str(caught.value)


def test_a_run_record_never_holds_the_twin_database_password(monkeypatch):
    from bim2rdt.config import settings_record

    monkeypatch.setenv("BIM2RDT_TWIN__URL", "postgresql+psycopg://robot:s3cret-pw@db.site:5432/twin")
    get_settings.cache_clear()
    settings = get_settings()
    assert settings.twin.url.endswith("robot:s3cret-pw@db.site:5432/twin")  # the twin itself gets the password
    assert settings_record(settings)["twin"]["url"] == "postgresql+psycopg://robot:***@db.site:5432/twin"
