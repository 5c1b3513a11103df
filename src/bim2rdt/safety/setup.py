"""Build the monitor from settings: the one place where ``Settings`` is unpacked into plain arguments."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path

from bim2rdt.config import Settings
from bim2rdt.safety.config import MonitorConfig
from bim2rdt.safety.monitor import HavMonitor
from bim2rdt.safety.sinks import EventSink


def monitor_config(settings: Settings, **overrides) -> MonitorConfig:
    """The monitor's configuration: ``settings.hav`` (its site is ``settings.mqtt.site``) with ``overrides``."""
    return MonitorConfig(**{**settings.hav.monitor_config().model_dump(), **overrides})


def open_monitor(settings: Settings, sinks: Sequence[EventSink] = (), clock: Callable[[], float] = time.time,
                 data_dir: Path | None = None, **overrides) -> HavMonitor:
    """A monitor storing its state under ``data_dir`` (default ``settings.data_dir/hav``)."""
    folder = data_dir if data_dir is not None else settings.data_dir / "hav"
    return HavMonitor(folder, settings.hav.site_secret, sinks, monitor_config(settings, **overrides), clock)
