"""Wire format of wearable acceleration batches: a small JSON header and packed little-endian samples.

MQTT carries no timestamp, so each batch says who sent it (``device``), its place in the device's stream
(``seq``, for de-duplication and ordering) and when its first sample was taken on the device clock
(``t_ms``, UTC epoch milliseconds). Samples are (n, 3) x/y/z in m/s^2, either int16 sensor counts with a
``scale`` (m/s^2 per count; full scale = 32767 * scale, what MEMS accelerometers emit) or float32.

Layout: b"HAV1", uint16 header length, UTF-8 JSON header, samples.
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass, replace
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, Strict, ValidationError, model_validator

from bim2rdt.errors import Bim2RdtError

MAGIC = b"HAV1"
_DTYPES = {"int16": np.dtype("<i2"), "float32": np.dtype("<f4")}
MAX_HEADER_BYTES = 1024
"""A header is a small flat object (~150 bytes); longer ones (or nesting) are refused before parsing."""
MAX_SEQ = 2**53 - 1
"""Sequence numbers are integers JSON and float64 hold exactly (and SQLite's INTEGER far beyond)."""
MAX_T_MS = 4_102_444_800_000.0
"""Device time bound: 2100-01-01 UTC in ms since the epoch (0 allows devices that count from boot)."""
MAX_RATE_HZ = 100_000.0
"""No wearable accelerometer samples faster (ISO 5349 needs up to ~2.5 kHz; MEMS parts stop at ~32 kHz)."""
MAX_BATCH_S = 60.0
"""A batch covers at most a minute of samples (a wearable sends a few per second)."""

StrictNumber = Annotated[float, Strict()]  # a JSON number, never a string; ints are numbers too


class PayloadError(Bim2RdtError):
    """A message on an accel topic that is not a well-formed batch."""


@dataclass(frozen=True, slots=True)
class AccelBatch:
    """Consecutive tri-axial samples from one wearable: ``xyz`` (n, 3) float32, m/s^2, at ``fs`` Hz.

    ``device_time`` is the first sample's time on the device clock, ``received_time`` when it reached us
    (both UTC epoch seconds); ``full_scale`` is the sensor range in m/s^2 (None when unknown); ``scale`` the
    m/s^2 per count when the samples came as int16 counts (``xyz`` = counts x float32(scale), exactly).
    """

    device: str
    seq: int
    device_time: float
    fs: float
    xyz: np.ndarray
    full_scale: float | None = None
    received_time: float | None = None
    scale: float | None = None

    @property
    def duration_s(self) -> float:
        """How long the batch lasts, seconds (samples over rate)."""
        return self.xyz.shape[0] / self.fs

    def received_at(self, when: float) -> AccelBatch:
        """A copy stamped with the monitor's receive time.

        Args:
            when: When the monitor received it, UTC seconds (the monitor's clock).

        Returns:
            The stamped batch.
        """
        return replace(self, received_time=when)


class AccelHeader(BaseModel):
    """The JSON header of an accel batch: every field typed (no strings for numbers, no floats for integers)
    and bounded, NaN and infinities refused; unknown extra fields are ignored."""

    model_config = ConfigDict(extra="ignore", allow_inf_nan=False, frozen=True)

    device: str = Field(pattern=r"^[A-Za-z0-9_.-]{1,64}$", strict=True)
    seq: int = Field(ge=0, le=MAX_SEQ, strict=True)
    t_ms: StrictNumber = Field(ge=0.0, le=MAX_T_MS)
    fs: StrictNumber = Field(gt=0.0, le=MAX_RATE_HZ)
    n: int = Field(ge=1, strict=True)
    dtype: Literal["int16", "float32"]
    scale: StrictNumber = Field(1.0, gt=0.0)
    full_scale: StrictNumber | None = Field(None, gt=0.0)

    @model_validator(mode="after")
    def _short_enough(self) -> AccelHeader:
        if self.n > self.fs * MAX_BATCH_S:
            raise ValueError(f"{self.n} samples at {self.fs:g} Hz is more than {MAX_BATCH_S:g} s in one batch")
        return self


def encode_accel(batch: AccelBatch, dtype: str = "int16") -> bytes:
    """Pack a batch for the bus: the HAV1 magic, a small JSON header, then the samples.

    Args:
        batch: Accelerations (n,3) in m/s^2 with device, sequence number, device time and rate.
        dtype: ``int16`` quantises to the batch's full scale (default 16 g) over 32767 counts; ``float32``
            keeps the values.

    Returns:
        The payload.
    """
    scale = (batch.full_scale or 16 * 9.80665) / 32767.0 if dtype == "int16" else 1.0
    samples = np.asarray(batch.xyz, dtype=np.float32)
    if dtype == "int16":  # float32 keeps counts to within 0.002 of their float64 values
        counts = np.rint(samples * np.float32(1.0 / scale))
        if not np.isfinite(counts).all():
            counts = np.nan_to_num(counts)
        samples = np.clip(counts, -32768, 32767, out=counts)
    header = {"device": batch.device, "seq": int(batch.seq), "t_ms": round(batch.device_time * 1000.0, 3),
              "fs": batch.fs, "n": int(samples.shape[0]), "dtype": dtype, "scale": scale,
              "full_scale": batch.full_scale}
    head = json.dumps(header, separators=(",", ":")).encode()
    return MAGIC + struct.pack("<H", len(head)) + head + samples.astype(_DTYPES[dtype]).tobytes()


def decode_accel(payload: bytes) -> AccelBatch:
    """Unpack a batch; PayloadError with the reason if it is not one. Nothing a payload holds gets past
    this unchecked: the header is one small flat JSON object whose every field is typed and bounded
    (:class:`AccelHeader`), and the samples fill the rest of the payload exactly.

    Args:
        payload: A message from a wearable's accel topic.

    Returns:
        The batch: (n,3) accelerations in m/s^2, device time in seconds, rate in Hz.

    Raises:
        PayloadError: Not an accel payload: no magic, a header too long, bad or out of bounds, or samples that
            do not fill the payload exactly.
    """
    if len(payload) < 6 or payload[:4] != MAGIC:
        raise PayloadError("accel payload does not start with the HAV1 magic")
    (head_len,) = struct.unpack("<H", payload[4:6])
    if head_len > MAX_HEADER_BYTES or 6 + head_len > len(payload):
        raise PayloadError(f"accel header of {head_len} bytes: at most {MAX_HEADER_BYTES}, within the payload")
    header = _header(payload[6:6 + head_len])
    dtype = _DTYPES[header.dtype]
    expected = 6 + head_len + 3 * header.n * dtype.itemsize
    if len(payload) != expected:
        raise PayloadError(f"accel payload is {len(payload)} bytes; its header says {expected} ({header.n} samples)")
    samples = np.frombuffer(payload, dtype=dtype, offset=6 + head_len, count=3 * header.n).reshape(header.n, 3)
    counts = dtype.kind == "i"
    xyz = samples.astype(np.float32) * np.float32(header.scale) if counts else samples.copy()
    return AccelBatch(header.device, header.seq, header.t_ms / 1000.0, header.fs, xyz, header.full_scale,
                      scale=header.scale if counts else None)


def _header(head: bytes) -> AccelHeader:
    try:
        return AccelHeader.model_validate_json(head)
    except ValidationError as error:
        first = error.errors()[0]
        field = ".".join(str(part) for part in first["loc"]) or "header"
        label = _LABELS.get(field, field)
        got = "" if first["type"] == "json_invalid" else f", got {str(first.get('input'))[:40]!r}"
        raise PayloadError(f"malformed accel header: {label}: {first['msg']}{got}") from None


_LABELS = {"device": "device id", "seq": "sequence number", "t_ms": "device time", "fs": "sampling rate",
           "n": "sample count", "dtype": "sample type", "scale": "count scale", "full_scale": "full scale"}


MAX_STATUS_BYTES = 4096


class WearableStatus(BaseModel):
    """A wearable's retained status message: ``online`` with who wears it on which tool, or offline."""

    model_config = ConfigDict(extra="ignore", frozen=True)

    online: bool = Field(strict=True)
    worker: str | None = Field(None, min_length=1, max_length=128, strict=True)
    tool: str = Field("unknown", min_length=1, max_length=64, strict=True)
    position: str = Field("handle", min_length=1, max_length=32, strict=True)
    zone: str | None = Field(None, max_length=128, strict=True)
    hand: Literal["", "left", "right"] = ""
    boot: str | None = Field(None, min_length=1, max_length=64, strict=True)
    """Names the device's current boot (a boot counter or a random id drawn at power-up): a new one tells the
    monitor the device restarted, so its seq and clock may start over (see ``safety.streams``)."""


def decode_status(payload: bytes) -> WearableStatus:
    """Read a wearable's status message; PayloadError with the reason if it is not one.

    Args:
        payload: A message from a wearable's status topic: one JSON object, at most ``MAX_STATUS_BYTES`` bytes.

    Returns:
        The status: online or offline, and who wears the device on which tool.

    Raises:
        PayloadError: The payload is too long, not JSON, or a field is missing, of the wrong type or out of bounds.
    """
    if len(payload) > MAX_STATUS_BYTES:
        raise PayloadError(f"status message of {len(payload)} bytes: at most {MAX_STATUS_BYTES}")
    try:
        return WearableStatus.model_validate_json(payload)
    except ValidationError as error:
        first = error.errors()[0]
        field = ".".join(str(part) for part in first["loc"]) or "message"
        raise PayloadError(f"malformed status: {field}: {first['msg']}") from None
