"""Hand-arm vibration safety: ISO 5349-1 exposure maths, the streaming monitor, mounting correction, privacy."""

from bim2rdt.safety.activity import Trigger
from bim2rdt.safety.errors import AccessDenied, HavError
from bim2rdt.safety.exposure import (EAV, ELV, a_hv, combine_exposures, daily_exposure, exposure_points,
                                     time_to_limit)
from bim2rdt.safety.monitor import HavMonitor, MonitorConfig, Session
from bim2rdt.safety.mounting import MountingCorrection
from bim2rdt.safety.privacy import IdentityMap, pseudonym
from bim2rdt.safety.sinks import BusSink, CallbackSink, EventSink, ListSink
from bim2rdt.safety.weighting import covered_band, weighted_rms, wh_weighting_factor

__all__ = ["EAV", "ELV", "AccessDenied", "BusSink", "CallbackSink", "EventSink", "HavError", "HavMonitor",
           "IdentityMap", "ListSink", "MonitorConfig", "MountingCorrection", "Session", "Trigger", "a_hv",
           "combine_exposures", "covered_band", "daily_exposure", "exposure_points", "pseudonym", "time_to_limit",
           "weighted_rms", "wh_weighting_factor"]
