"""Typed settings, loaded once at the edge (env prefix ``BIM2RDT_``, nested with ``__``).

Core classes never take a ``Settings``; the CLI and the orchestrator unpack the fields they need into plain
arguments. Example: ``BIM2RDT_LLM__MODEL=gpt-4o-mini``, ``BIM2RDT_SAMPLES=/data/ifc``,
``BIM2RDT_MISSION__MOVED_TRANSLATION=0.1``. ``Settings`` gathers each package's own config section
(``registration.IcpConfig``, ``mission.MissionConfig``, ``semantics.LlmPriorsConfig``), so this module sits above
the library in the import layers (.importlinter): library code never imports it. A run writes
:func:`settings_record` of what it ran with next to its results.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

from pydantic import BaseModel, Field, ValidationError, model_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

from bim2rdt.errors import Bim2RdtError
from bim2rdt.mission.config import MissionConfig
from bim2rdt.registration.config import IcpConfig
from bim2rdt.safety.config import MonitorConfig
from bim2rdt.semantics.llm import LlmPriorsConfig
from bim2rdt.twin.config import TwinConfig


def default_samples_dir() -> Path:
    """Where real IFC samples are when ``samples`` is unset: ``../shared/data/ifc`` beside the checkout this
    package runs from (this file is ``<checkout>/src/bim2rdt/config.py``)."""
    return Path(__file__).resolve().parents[2].parent / "shared" / "data" / "ifc"


def _default_cache_dir() -> Path:
    return Path.home() / ".cache" / "bim2rdt"


class BimSettings(BaseModel):
    """IFC reading and writing."""

    tessellation_cache: bool = Field(True, description="Cache tessellated meshes on disk, keyed by file hash.")


class HavSettings(MonitorConfig):
    """Hand-arm vibration monitoring: the monitor's configuration (defaults in :class:`MonitorConfig`; ``site``
    always follows ``mqtt.site``) and the key of the worker pseudonyms."""

    site_secret: str = Field("change-me", description="Key for worker pseudonyms (keyed hash).")

    def monitor_config(self, **overrides) -> MonitorConfig:
        """The monitor's part with ``overrides``, without the secret (the monitor takes it as its own argument)."""
        return MonitorConfig(**{**self.model_dump(include=set(MonitorConfig.model_fields)), **overrides})


class MqttSettings(BaseModel):
    """The site event bus."""

    host: str | None = Field(None, description="Broker host; None means the in-process bus.")
    port: int = Field(1883, description="Broker port.")
    site: str = Field("demo", description="Site id used in topic names site/{site}/...")
    username: str = Field("monitor", description="Broker user of the HAV monitor (the shipped ACL's reader).")
    session_expiry_s: int = Field(3600, description="How long the broker queues QoS 1 messages for a stopped "
                                  "monitor (MQTT 5 session expiry), seconds.")
    password: str | None = Field(None, description="Monitor's broker password; None derives it from device_secret.")
    device_secret: str = Field("change-me-devices", description="Dev provisioning: device passwords are keyed "
                               "hashes of their ids with this secret (bim2rdt hav broker, sim wearables).")


class Settings(BaseSettings):
    """All settings of bim2rdt. Read once with :func:`get_settings`."""

    model_config = SettingsConfigDict(env_prefix="BIM2RDT_", env_nested_delimiter="__", extra="ignore")

    samples: Path | None = Field(None, description="Folder of real IFC sample files used by tests/benchmarks "
                                                    "(unset: ../shared/data/ifc beside the checkout).")
    cache_dir: Path = Field(default_factory=_default_cache_dir, description="On-disk caches (meshes, LLM answers).")
    data_dir: Path = Field(Path("var"), description="Persistent state (SQLite exposure store, twin history).")
    bim: BimSettings = BimSettings()
    llm: LlmPriorsConfig = LlmPriorsConfig()
    hav: HavSettings = HavSettings()
    mqtt: MqttSettings = MqttSettings()
    registration: IcpConfig = IcpConfig()
    mission: MissionConfig = MissionConfig()
    twin: TwinConfig = TwinConfig()

    @model_validator(mode="after")
    def _one_site(self) -> Settings:
        """The monitor reads the topics of the bus's site: ``hav.site`` follows ``mqtt.site``."""
        if "site" not in self.hav.model_fields_set:
            self.hav = self.hav.model_copy(update={"site": self.mqtt.site})
        elif self.hav.site != self.mqtt.site:
            raise ValueError(f"hav.site {self.hav.site!r} differs from mqtt.site {self.mqtt.site!r}: set "
                             "BIM2RDT_MQTT__SITE only")
        return self


SECRET_WORDS = ("secret", "password", "api_key")
"""Settings whose name holds one of these are masked in a run's record (a config.json is shared with results)."""


def settings_record(settings: Settings) -> dict:
    """The resolved settings that ran, as JSON-ready data for a run's ``config.json`` or results: every section,
    secrets masked ("***" where one is set)."""
    return _masked(settings.model_dump(mode="json"))


def _masked(value: object) -> object:
    if not isinstance(value, dict):
        return value
    return {key: "***" if any(word in key for word in SECRET_WORDS) and item is not None else _masked(item)
            for key, item in value.items()}


class ConfigError(Bim2RdtError):
    """A setting from the environment failed validation; the message names the variable."""


@lru_cache(maxsize=1)
def get_settings() -> Settings:
    """The process-wide settings, read from the environment once. Raises :class:`ConfigError` on a bad value."""
    try:
        return Settings()
    except ValidationError as error:
        first = error.errors()[0]
        variable = "BIM2RDT_" + "__".join(str(part) for part in first["loc"]).upper()
        raise ConfigError(f"{variable}: {first['msg']} (got {first.get('input')!r})") from error
