"""Typed settings, loaded once at the edge (env prefix ``BIM2RDT_``, nested with ``__``).

Core classes never take a ``Settings``; the CLI and the orchestrator unpack the fields they need into plain
arguments. Example: ``BIM2RDT_LLM__MODEL=gpt-4o-mini``, ``BIM2RDT_SAMPLES=/data/ifc``.
"""

from __future__ import annotations

import os
import re
import tempfile
from functools import lru_cache
from pathlib import Path

from pydantic import BaseModel, Field, ValidationError
from pydantic_settings import BaseSettings, SettingsConfigDict
from pydantic_settings.exceptions import SettingsError

from bim2rdt.errors import Bim2RdtError
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


class ConfigError(Bim2RdtError):
    """A setting from the environment failed validation; the message names the variable."""


@lru_cache(maxsize=1)
def get_settings() -> Settings:
    """The process-wide settings, read from the environment once. Raises :class:`ConfigError` on a bad value
    (including a whole section given as bad JSON, and a folder setting that names an existing file)."""
    try:
        settings = Settings()
    except ValidationError as error:
        first = error.errors()[0]
        variable = _variable(first["loc"])
        raise ConfigError(f"{variable}: {first['msg']} (got {first.get('input')!r})") from error
    except SettingsError as error:  # a nested section set as one variable whose JSON does not parse
        raise ConfigError(_settings_error(error)) from error
    for name in ("cache_dir", "data_dir"):
        folder = getattr(settings, name)
        if folder.exists() and not folder.is_dir():
            raise ConfigError(f"BIM2RDT_{name.upper()}: {folder} is a file, not a folder")
    return settings


def usable_folder(folder: Path, variable: str) -> Path:
    """Create a folder a setting names and probe it with a temporary file, before any long work writes there;
    a ConfigError names the variable and the system's reason (read-only, /proc, a file in the path ...)."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError as error:
        raise ConfigError(f"{variable}: cannot write into {folder}: {error.strerror or error}") from error
    return folder


def ifc_cache_dir(settings: Settings) -> Path | None:
    """Where ``load_ifc`` caches read models (``cache_dir/ifc``, checked writable), or None with
    ``BIM2RDT_BIM__TESSELLATION_CACHE=false``."""
    if not settings.bim.tessellation_cache:
        return None
    return usable_folder(settings.cache_dir / "ifc", "BIM2RDT_CACHE_DIR")


def _variable(loc: tuple) -> str:
    """The variable the user set for a failing field: ``BIM2RDT_MQTT__PORT``, or ``BIM2RDT_MQTT`` (field port)
    when the section came as one JSON variable."""
    names = ["BIM2RDT_" + "__".join(str(part) for part in loc[:n]).upper() for n in range(len(loc), 0, -1)]
    present = {key.upper() for key in os.environ}
    chosen = next((name for name in names if name in present), names[0])
    inner = ".".join(str(part) for part in loc[len(chosen.split("__")):])
    return f"{chosen} (field {inner})" if inner and chosen != names[0] else chosen


def _settings_error(error: SettingsError) -> str:
    """'error parsing value for field "mqtt" from source ...' -> 'BIM2RDT_MQTT: not valid JSON (...)'."""
    field = re.search(r'field "([^"]+)"', str(error))
    variable = f"BIM2RDT_{field.group(1).upper()}" if field else "a BIM2RDT_ variable"
    cause = error.__cause__
    detail = f"not valid JSON ({cause})" if isinstance(cause, ValueError) else str(error)
    return f"{variable}: {detail}; set a whole section as a JSON object, or one field as {variable}__FIELD"
