"""Typed settings, loaded once at the edge (env prefix ``BIM2RDT_``, nested with ``__``).

Core classes never take a ``Settings``; the CLI and the orchestrator unpack the fields they need into plain
arguments. Example: ``BIM2RDT_LLM__MODEL=gpt-4o-mini``, ``BIM2RDT_SAMPLES=/data/ifc``.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

from pydantic import BaseModel, Field, ValidationError
from pydantic_settings import BaseSettings, SettingsConfigDict

from bim2rdt.errors import Bim2RdtError
from bim2rdt.localization.config import LocalizationConfig
from bim2rdt.registration.config import IcpConfig
from bim2rdt.semantics.llm import LlmPriorsConfig


def _default_cache_dir() -> Path:
    return Path.home() / ".cache" / "bim2rdt"


class BimSettings(BaseModel):
    """IFC reading and writing."""

    tessellation_cache: bool = Field(True, description="Cache tessellated meshes on disk, keyed by file hash.")


class HavSettings(BaseModel):
    """Hand-arm vibration monitoring."""

    site_secret: str = Field("change-me", description="Key for worker pseudonyms (keyed hash).")
    raw_retention_s: float = Field(7 * 24 * 3600.0, description="How long raw sensor windows are kept, seconds.")
    start_threshold: float = Field(1.0, description="Block a_hv (m/s^2) at which a tool activity starts (trigger).")
    stop_threshold: float = Field(0.5, description="Block a_hv (m/s^2) under which an activity is winding down.")
    stop_hold_s: float = Field(2.0, description="Seconds under stop_threshold that end an activity.")
    predict_every_s: float = Field(60.0, description="Activity seconds between predictions of the time to EAV.")
    reorder_s: float = Field(2.0, description="Seconds a batch waits for a missing predecessor before a gap.")
    max_reorder: int = Field(8, description="Out-of-order batches held before a missing one is declared a gap.")
    crest_limit: float = Field(25.0, description="Crest factor above which a block is a shock artefact.")


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

    samples: Path | None = Field(None, description="Folder of real IFC sample files used by tests/benchmarks.")
    cache_dir: Path = Field(default_factory=_default_cache_dir, description="On-disk caches (meshes, LLM answers).")
    data_dir: Path = Field(Path("var"), description="Persistent state (SQLite exposure store, twin history).")
    bim: BimSettings = BimSettings()
    llm: LlmPriorsConfig = LlmPriorsConfig()
    hav: HavSettings = HavSettings()
    mqtt: MqttSettings = MqttSettings()
    registration: IcpConfig = IcpConfig()
    localization: LocalizationConfig = LocalizationConfig()


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
