"""Build the monitor from settings: the one place where ``Settings`` is unpacked into plain arguments."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

from bim2rdt.config import Settings
from bim2rdt.safety.activity import Trigger
from bim2rdt.safety.blocks import ArtefactLimits
from bim2rdt.safety.monitor import HavMonitor, MonitorConfig
from bim2rdt.safety.sinks import EventSink


def monitor_config(settings: Settings, **overrides) -> MonitorConfig:
    """The monitor's configuration from ``settings.hav`` and ``settings.mqtt.site``."""
    hav = settings.hav
    trigger = Trigger(hav.start_threshold, hav.stop_threshold, hav.stop_hold_s, hav.predict_every_s)
    values = {"site": settings.mqtt.site, "trigger": trigger, "artefacts": ArtefactLimits(crest_limit=hav.crest_limit),
              "max_reorder": hav.max_reorder, "reorder_s": hav.reorder_s, "raw_retention_s": hav.raw_retention_s}
    return MonitorConfig(**{**values, **overrides})


def open_monitor(settings: Settings, sinks: Sequence[EventSink] = (), clock: Callable[[], float] = time.time,
                 **overrides) -> HavMonitor:
    """A monitor storing its state under ``settings.data_dir/hav``."""
    return HavMonitor(settings.data_dir / "hav", settings.hav.site_secret, sinks, monitor_config(settings, **overrides),
                      clock)
