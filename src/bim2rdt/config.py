"""Typed settings, loaded once at the edge (env prefix ``BIM2RDT_``, nested with ``__``).

Core classes never take a ``Settings``; the CLI and the orchestrator unpack the fields they need into plain
arguments. Example: ``BIM2RDT_LLM__MODEL=gpt-4o-mini``, ``BIM2RDT_SAMPLES=/data/ifc``,
``BIM2RDT_MISSION__MOVED_TRANSLATION=0.1``. ``Settings`` gathers each package's own config section
(``registration.IcpConfig``, ``mission.MissionConfig``, ``semantics.LlmPriorsConfig``), so this module sits above
the library in the import layers (.importlinter): library code never imports it. A run writes
:func:`settings_record` of what it ran with next to its results.
"""

from __future__ import annotations

import os
import re
import tempfile
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

from pydantic import BaseModel, Field, ValidationError, model_validator
from pydantic_settings import BaseSettings, SettingsConfigDict
from pydantic_settings.exceptions import SettingsError

from bim2rdt.errors import Bim2RdtError
from bim2rdt.localization.config import LocalizationConfig
from bim2rdt.mission.config import MissionConfig
from bim2rdt.perception import PerceptionConfig
from bim2rdt.registration.config import IcpConfig
from bim2rdt.safety.config import MonitorConfig
from bim2rdt.semantics.llm import LlmPriorsConfig
from bim2rdt.server.config import ServerConfig
from bim2rdt.sources import SourcesConfig
from bim2rdt.sources.ros_config import RosConfig
from bim2rdt.structure.config import StructureConfig
from bim2rdt.twin.config import TwinConfig
from bim2rdt.twin.judge import JudgeConfig
from bim2rdt.verify import VerifyConfig, real_sensor_localization
from bim2rdt.twin.progress_config import ProgressConfig

if TYPE_CHECKING:
    from bim2rdt.bus.nats_bus import StreamLimits


def default_samples_dir() -> Path:
    """Where real IFC samples are when ``samples`` is unset.

    Returns:
        ``../shared/data/ifc`` beside the checkout this package runs from (this file is
            ``<checkout>/src/bim2rdt/config.py``); it may not exist.
    """
    return Path(__file__).resolve().parents[2].parent / "shared" / "data" / "ifc"


def _default_cache_dir() -> Path:
    return Path.home() / ".cache" / "bim2rdt"


MIN_SECRET_LENGTH = 8
"""The shortest broker password or secret accepted (characters): NIST SP 800-63B's minimum for a memorized
secret (decision 0036). A site generates longer ones (``openssl rand -hex 32``); the shipped defaults are refused
outside --dev whatever their length."""


class BimSettings(BaseModel):
    """IFC reading and writing."""

    tessellation_cache: bool = Field(True, description="Cache tessellated meshes on disk, keyed by file hash.")


class HavSettings(MonitorConfig):
    """Hand-arm vibration monitoring: the monitor's configuration (defaults in :class:`MonitorConfig`; ``site``
    always follows ``mqtt.site``) and the key of the worker pseudonyms."""

    site_secret: str = Field("change-me", min_length=MIN_SECRET_LENGTH, description="Key for worker pseudonyms "
                             "(keyed hash); the shipped default is refused outside --dev.")

    ack_wait_s: float = Field(30.0, gt=0, le=3600, description="NATS path: seconds JetStream waits for a monitor's "
                              "acknowledgement (sent after the commit) before redelivering a message.")
    max_deliver: int = Field(20, ge=2, le=10_000, description="NATS path: deliveries of one message at most, "
                             "counted across monitor restarts; on its last one a message whose commit keeps failing "
                             "is dead-lettered under its device (with the reason) and terminated.")

    stream_replicas: int = Field(1, ge=1, le=5, description="NATS path: replicas of the HAV stream when a monitor "
                                 "creates it (3 on a 3-node cluster).")
    stream_max_age_s: float = Field(24 * 3600.0, gt=0, description="NATS path: JetStream keeps wearable messages "
                                    "at most this long, seconds (then the oldest go).")
    stream_max_bytes: int = Field(8 * 2**30, gt=0, description="NATS path: JetStream keeps at most this many bytes of "
                                  "wearable messages (then the oldest go).")
    stream_devices: int = Field(32, ge=1, le=100_000, description="NATS path: the devices the stream's bytes are "
                                "shared by; each keeps at most stream_max_bytes / stream_devices, so one device's "
                                "flood evicts only its own messages (decision 0037).")

    def stream_limits(self) -> StreamLimits:
        """The HAV stream's limits from these settings (:class:`~bim2rdt.bus.nats_bus.StreamLimits`).

        Returns:
            The limits a monitor or ``hav broker --nats`` creates or updates the stream with.
        """
        from bim2rdt.bus.nats_bus import StreamLimits

        return StreamLimits(self.stream_max_age_s, self.stream_max_bytes, self.stream_replicas,
                            self.max_message_bytes, self.stream_devices)

    def monitor_config(self, **overrides: object) -> MonitorConfig:
        """The monitor's part of these settings, without the secret (the monitor takes it as its own argument).

        Args:
            **overrides: Fields of :class:`MonitorConfig` to set instead of these settings' values.

        Returns:
            A validated :class:`MonitorConfig`.
        """
        return MonitorConfig(**{**self.model_dump(include=set(MonitorConfig.model_fields)), **overrides})


class MqttSettings(BaseModel):
    """The site event bus."""

    host: str | None = Field(None, min_length=1, description="Broker host; None means the in-process bus.")
    port: int = Field(1883, ge=1, le=65535, description="Broker port.")
    site: str = Field("demo", pattern=r"^[A-Za-z0-9_.-]{1,64}$", description="Site id used in topic names "
                      "site/{site}/... (one topic level: letters, digits, _ . -).")
    username: str = Field("monitor", pattern=r"^[A-Za-z0-9_.-]{1,64}$", description="Broker user of the HAV "
                          "monitor (its own credential; the ACL's reader of the site).")
    session_expiry_s: int = Field(3600, ge=0, description="How long the broker queues QoS 1 messages for a "
                                  "stopped monitor (MQTT 5 session expiry), seconds.")
    password: str | None = Field(None, min_length=MIN_SECRET_LENGTH, description="The monitor's own broker "
                                 "password; required outside --dev (with --dev, derived from device_secret).")
    device_secret: str = Field("change-me-devices", min_length=MIN_SECRET_LENGTH, description="Dev provisioning: "
                               "device passwords are keyed hashes of their ids with this secret (hav broker, sim "
                               "wearables); the shipped default is refused outside --dev.")


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
    localization: LocalizationConfig = LocalizationConfig()
    mission: MissionConfig = MissionConfig()
    perception: PerceptionConfig = PerceptionConfig()
    verify: VerifyConfig = VerifyConfig()
    twin: TwinConfig = TwinConfig()
    judge: JudgeConfig = JudgeConfig()
    structure: StructureConfig = StructureConfig()
    progress: ProgressConfig = ProgressConfig()
    server: ServerConfig = ServerConfig()
    ros: RosConfig = RosConfig()
    sources: SourcesConfig = SourcesConfig()

    @model_validator(mode="after")
    def _one_site(self) -> Settings:
        """The monitor reads the topics of the bus's site: ``hav.site`` follows ``mqtt.site``."""
        if "site" not in self.hav.model_fields_set:
            self.hav = self.hav.model_copy(update={"site": self.mqtt.site})
        elif self.hav.site != self.mqtt.site:
            raise ValueError(f"hav.site {self.hav.site!r} differs from mqtt.site {self.mqtt.site!r}: set "
                             "BIM2RDT_MQTT__SITE only")
        return self

    @model_validator(mode="after")
    def _one_localization(self) -> Settings:
        """verify localizes with ``localization`` (the real sensor's defaults where it sets nothing), judges as the
        mission does (``judge``) and trusts fits as the twin does (``twin.min_fitness``): one place to set each."""
        if "localization" in self.verify.model_fields_set:
            raise ValueError("verify.localization follows localization: set BIM2RDT_LOCALIZATION__* only")
        if "judge" in self.verify.model_fields_set:
            raise ValueError("verify.judge follows judge: set BIM2RDT_JUDGE__* only")
        follow = {"localization": real_sensor_localization(self.localization), "judge": self.judge}
        if "min_fitness" not in self.verify.model_fields_set:
            follow["min_fitness"] = self.twin.min_fitness
        self.verify = self.verify.model_copy(update=follow)
        return self


SECRET_WORDS = ("secret", "password", "api_key", "tokens")
"""Settings whose name holds one of these are masked in a run's record (a config.json is shared with results)."""
URL_PASSWORD = re.compile(r"(:/+[^:/@\s]*:)[^\s]*@")
"""The password of a URL (``scheme://user:password@host``): masked in every setting, whatever its name
(``hav.store_url`` was printed in clear)."""


def settings_record(settings: Settings) -> dict:
    """The resolved settings that ran, as JSON-ready data for a run's ``config.json`` or results.

    Args:
        settings: The settings in force.

    Returns:
        Every section as nested dicts; a setting whose name holds a word of ``SECRET_WORDS`` reads "***" where
            one is set, and the password of any URL in any setting reads "***".
    """
    return _masked(settings.model_dump(mode="json"))


def _masked(value: object) -> object:
    if isinstance(value, str):
        return URL_PASSWORD.sub(r"\1***@", value)
    if isinstance(value, list):
        return [_masked(item) for item in value]
    if not isinstance(value, dict):
        return value
    return {key: "***" if any(word in key for word in SECRET_WORDS) and item is not None else _masked(item)
            for key, item in value.items()}


class ConfigError(Bim2RdtError):
    """A setting from the environment failed validation; the message names the variable."""


@lru_cache(maxsize=1)
def get_settings() -> Settings:
    """The process-wide settings, read from the ``BIM2RDT_*`` environment once and cached.

    Returns:
        The validated :class:`Settings`.

    Raises:
        ConfigError: A bad value, a whole section given as bad JSON, or a folder setting that names an existing
            file; the message names the variable.
    """
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
    """Create a folder a setting names and probe it with a temporary file, before any long work writes there.

    Args:
        folder: The folder to create (with its parents) and probe.
        variable: The environment variable that set it, named in the error.

    Returns:
        ``folder``.

    Raises:
        ConfigError: The folder cannot be created or written (read-only, /proc, a file in the path ...); the
            message names the variable and the system's reason.
    """
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError as error:
        raise ConfigError(f"{variable}: cannot write into {folder}: {error.strerror or error}") from error
    return folder


def ifc_cache_dir(settings: Settings) -> Path | None:
    """Where ``load_ifc`` caches read models.

    Args:
        settings: The settings in force.

    Returns:
        ``cache_dir/ifc``, created and checked writable, or None with ``BIM2RDT_BIM__TESSELLATION_CACHE=false``.

    Raises:
        ConfigError: The cache folder cannot be written (from :func:`usable_folder`).
    """
    if not settings.bim.tessellation_cache:
        return None
    return usable_folder(settings.cache_dir / "ifc", "BIM2RDT_CACHE_DIR")


def _variable(loc: tuple) -> str:
    """The variable the user set for a failing field: ``BIM2RDT_MQTT__PORT``, or ``BIM2RDT_MQTT`` (field port)
    when the section came as one JSON variable; a check across sections (no location) names none."""
    if not loc:
        return "BIM2RDT settings"
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
