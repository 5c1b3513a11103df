"""Hand-arm vibration safety: ISO 5349-1 exposure maths, the streaming monitor, mounting correction, privacy.

Names are imported on first use (PEP 562), so ``bim2rdt.safety.config`` (read by the settings) loads without the
signal-processing stack.
"""

from __future__ import annotations

import importlib

_HOMES = {
    "Trigger": "config", "ArtefactLimits": "config", "MonitorConfig": "config",
    "AccessDenied": "errors", "HavError": "errors",
    "EAV": "exposure", "ELV": "exposure", "a_hv": "exposure", "combine_exposures": "exposure",
    "T0_S": "exposure", "ACTIVITY_ENDED": "activity", "ACTIVITY_STARTED": "activity", "IfcSink": "ifc_sink",
    "daily_exposure": "exposure", "exposure_points": "exposure", "time_to_limit": "exposure",
    "HavMonitor": "monitor", "MonitorQueries": "queries", "Session": "sessions", "MountingCorrection": "mounting",
    "IdentityMap": "privacy", "PartitionIdentities": "privacy", "pseudonym": "privacy",
    "BusSink": "sinks", "CallbackSink": "sinks", "EventSink": "sinks", "ListSink": "sinks",
    "covered_band": "weighting", "weighted_rms": "weighting", "wh_weighting_factor": "weighting",
}


def __getattr__(name: str):
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module 'bim2rdt.safety' has no attribute {name!r}")
    return getattr(importlib.import_module(f"bim2rdt.safety.{home}"), name)


def __dir__() -> list[str]:
    return sorted(__all__)


__all__ = sorted(_HOMES)
