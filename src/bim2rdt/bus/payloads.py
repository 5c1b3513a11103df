"""Wire format of wearable acceleration batches: a small JSON header and packed little-endian samples.

MQTT carries no timestamp, so each batch says who sent it (``device``), its place in the device's stream
(``seq``, for de-duplication and ordering) and when its first sample was taken on the device clock
(``t_ms``, UTC epoch milliseconds). Samples are (n, 3) x/y/z in m/s^2, either int16 sensor counts with a
``scale`` (m/s^2 per count; full scale = 32767 * scale, what MEMS accelerometers emit) or float32.

Layout: b"HAV1", uint16 header length, UTF-8 JSON header, samples.
"""

from __future__ import annotations

import json
import math
import struct
from dataclasses import dataclass, replace

import numpy as np

from bim2rdt.errors import Bim2RdtError

MAGIC = b"HAV1"
_DTYPES = {"int16": np.dtype("<i2"), "float32": np.dtype("<f4")}


class PayloadError(Bim2RdtError):
    """A message on an accel topic that is not a well-formed batch."""


@dataclass(frozen=True)
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
        return self.xyz.shape[0] / self.fs

    def received_at(self, when: float) -> AccelBatch:
        return replace(self, received_time=when)


def encode_accel(batch: AccelBatch, dtype: str = "int16") -> bytes:
    """Pack a batch; int16 quantises to the batch's full scale (default 16 g) over 32767 counts."""
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
    """Unpack a batch; PayloadError with the reason if it is not one."""
    if len(payload) < 6 or payload[:4] != MAGIC:
        raise PayloadError("accel payload does not start with the HAV1 magic")
    (head_len,) = struct.unpack("<H", payload[4:6])
    try:
        header = json.loads(payload[6:6 + head_len])
        fs, n, t_ms = float(header["fs"]), int(header["n"]), float(header["t_ms"])
        _check_header(fs, n, t_ms)
        dtype = _DTYPES[header["dtype"]]
        samples = np.frombuffer(payload, dtype=dtype, offset=6 + head_len, count=3 * n).reshape(n, 3)
        xyz = (samples.astype(np.float32) * np.float32(header["scale"])) if dtype.kind == "i" else samples.copy()
        return AccelBatch(str(header["device"]), int(header["seq"]), t_ms / 1000.0, fs, xyz,
                          header.get("full_scale"), scale=float(header["scale"]) if dtype.kind == "i" else None)
    except (ValueError, KeyError, TypeError) as error:
        raise PayloadError(f"malformed accel payload: {error}") from error


def _check_header(fs: float, n: int, t_ms: float) -> None:
    """ValueError for a header no stream can use: no positive finite rate, no samples, no device time."""
    if not (math.isfinite(fs) and fs > 0):
        raise ValueError(f"sampling rate must be a positive number of Hz, got {fs!r}")
    if n < 1:
        raise ValueError(f"sample count must be at least 1, got {n}")
    if not math.isfinite(t_ms):
        raise ValueError(f"device time must be a finite epoch in ms, got {t_ms!r}")
