"""Wire format of on-device exposure summaries: one small JSON object per second of samples (~200 bytes).

A wearable that weighs its own samples (ISO 5349-1 Wh, as commercial HAV wearables do) sends, instead of raw
batches, one summary per second on ``site/{site}/wearable/{device}/summary``: per-axis frequency-weighted r.m.s.
over the second (``ahw``, m/s^2), the unweighted per-axis peak (``peak``, m/s^2) and whether the sensor saturated
(``sat``). ``seq`` counts the device's summaries (de-duplication, order), ``t_ms`` is the second's first sample on
the device clock (UTC epoch ms, or ms since boot), ``s`` the seconds it covers, ``fs`` the device's sampling rate.
75x less bandwidth than 0.5 s int16 batches at 5 kHz.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, Strict, ValidationError

from bim2rdt.bus.payloads import MAX_RATE_HZ, MAX_SEQ, MAX_T_MS, PayloadError
from bim2rdt.bus.topics import check_level

MAX_SUMMARY_BYTES = 1024
MAX_WEIGHTED = 5000.0
"""m/s^2: no weighted r.m.s. is larger (the monitor's physical limit on any sample)."""
Number = Annotated[float, Strict()]
Axis = Annotated[float, Strict(), Field(ge=0.0, le=MAX_WEIGHTED)]
Peak = Annotated[float, Strict(), Field(ge=0.0, le=1e6)]


@dataclass(frozen=True, slots=True)
class DeviceSummary:
    """One second (``seconds``) of a wearable's on-device weighing.

    ``device_time`` is the first sample's time on the device clock, ``received_time`` when the summary reached us
    (both seconds; None until stamped); ``fs`` the device's sampling rate, Hz; ``ahw`` the per-axis
    frequency-weighted r.m.s. and ``peak`` the unweighted per-axis peak, m/s^2; ``saturated`` whether the sensor
    saturated; ``full_scale`` the sensor range, m/s^2 (None when unknown).
    """

    device: str
    seq: int
    device_time: float
    seconds: float
    fs: float
    ahw: tuple[float, float, float]
    peak: tuple[float, float, float]
    saturated: bool = False
    full_scale: float | None = None
    received_time: float | None = None

    @property
    def energy(self) -> float:
        """Weighted energy of the second, m^2/s^3: (a_hwx^2 + a_hwy^2 + a_hwz^2) x seconds (what the raw path's
        blocks carry)."""
        x, y, z = self.ahw
        return (x * x + y * y + z * z) * self.seconds

    @property
    def end_time(self) -> float:
        """When the second's samples end on the device clock, seconds: ``device_time + seconds``."""
        return self.device_time + self.seconds

    def received_at(self, when: float) -> DeviceSummary:
        """A copy stamped with the monitor's receive time.

        Args:
            when: When the monitor received it, seconds (the monitor's clock).

        Returns:
            The stamped summary.
        """
        return replace(self, received_time=when)


class SummaryMessage(BaseModel):
    """The JSON of a summary: strict types, bounded, no NaN or infinities; extra fields ignored."""

    model_config = ConfigDict(extra="ignore", allow_inf_nan=False, frozen=True)

    device: str = Field(pattern=r"^[A-Za-z0-9_.-]{1,64}$", strict=True)
    seq: int = Field(ge=0, le=MAX_SEQ, strict=True)
    t_ms: Number = Field(ge=0.0, le=MAX_T_MS)
    s: Number = Field(gt=0.0, le=60.0)
    fs: Number = Field(gt=0.0, le=MAX_RATE_HZ)
    ahw: tuple[Axis, Axis, Axis]
    peak: tuple[Peak, Peak, Peak]
    sat: bool = Field(False, strict=True)
    full_scale: Number | None = Field(None, gt=0.0)


def summary_topic(site: str, device: str) -> str:
    return f"site/{check_level(site, 'site')}/wearable/{check_level(device, 'device')}/summary"


def encode_summary(summary: DeviceSummary) -> bytes:
    body = {"device": summary.device, "seq": int(summary.seq), "t_ms": round(summary.device_time * 1000.0, 3),
            "s": summary.seconds, "fs": summary.fs, "ahw": [round(float(v), 6) for v in summary.ahw],
            "peak": [round(float(v), 3) for v in summary.peak], "sat": bool(summary.saturated)}
    if summary.full_scale is not None:
        body["full_scale"] = summary.full_scale
    return json.dumps(body, separators=(",", ":")).encode()


def decode_summary(payload: bytes) -> DeviceSummary:
    """Read a wearable's on-device summary; PayloadError with the reason if the payload is not one.

    Args:
        payload: A message from a wearable's summary topic: one JSON object, at most ``MAX_SUMMARY_BYTES`` bytes.

    Returns:
        The summary, its device time converted from ms to seconds.

    Raises:
        PayloadError: The payload is too long, not JSON, or a field is missing, of the wrong type or out of bounds.
    """
    if len(payload) > MAX_SUMMARY_BYTES:
        raise PayloadError(f"summary of {len(payload)} bytes: at most {MAX_SUMMARY_BYTES}")
    try:
        message = SummaryMessage.model_validate_json(payload)
    except ValidationError as error:
        first = error.errors()[0]
        field = ".".join(str(part) for part in first["loc"]) or "message"
        raise PayloadError(f"malformed summary: {field}: {first['msg']}") from None
    return DeviceSummary(message.device, message.seq, message.t_ms / 1000.0, message.s, message.fs,
                         tuple(message.ahw), tuple(message.peak), message.sat, message.full_scale)
