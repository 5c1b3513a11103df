"""The Azure Kinect (k4a) recording conventions, as the Azure Kinect Sensor SDK defines them.

- Calibration JSON (attached to the .mkv as ``calibration.json``): per camera, ``ModelParameters`` are
  (cx, cy, fx, fy, k1..k6, codx, cody, p2, p1), unitized by the sensor's resolution and 0-cornered; a mode's
  intrinsics scale them to the mode's binned resolution, subtract its crop offset, then subtract 0.5 px (the SDK's
  ``transformation_get_mode_specific_camera_calibration``). ``Rt`` of a camera or inertial sensor maps depth-camera
  coordinates into that sensor's: ``p_sensor = R p_depth + t`` (t in metres).
- IMU track: one block per sample, 40 bytes little-endian, packed: uint64 accelerometer time (ns), float32[3]
  accelerometer (m/s^2, the IMU's frame), uint64 gyroscope time (ns), float32[3] gyroscope (rad/s)
  (``matroska_imu_sample_t``). The SDK hands these on raw; the calibration's accelerometer bias and mixing matrix
  (cubic polynomials in temperature, 4 coefficients per entry) correct them: ``a = M (raw - b)``. The samples carry
  no temperature, so the polynomials are evaluated at the calibration's own ``TemperatureC``.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

import numpy as np

from bim2rdt.perception import Intrinsics

DEPTH_MODES = {  # mode -> (binned resolution, crop offset, output resolution)
    "NFOV_2X2BINNED": ((512, 512), (96, 90), (320, 288)),
    "NFOV_UNBINNED": ((1024, 1024), (192, 180), (640, 576)),
    "WFOV_2X2BINNED": ((512, 512), (0, 0), (512, 512)),
    "WFOV_UNBINNED": ((1024, 1024), (0, 0), (1024, 1024)),
    "PASSIVE_IR": ((1024, 1024), (0, 0), (1024, 1024)),
}
COLOR_MODES = {  # by output height, from a 4:3 calibration
    720: ((1280, 960), (0, 120), (1280, 720)),
    1080: ((1920, 1440), (0, 180), (1920, 1080)),
    1440: ((2560, 1920), (0, 240), (2560, 1440)),
    1536: ((2048, 1536), (0, 0), (2048, 1536)),
    2160: ((3840, 2880), (0, 360), (3840, 2160)),
    3072: ((4096, 3072), (0, 0), (4096, 3072)),
}
IMU_SAMPLE = struct.Struct("<Q3fQ3f")


@dataclass(frozen=True)
class Lens:
    """A mode's pinhole ``intrinsics`` and its OpenCV distortion (k1, k2, p1, p2, k3, k4, k5, k6), and the
    rotation ``R`` and translation ``t`` (m) from depth-camera to this camera's coordinates."""

    intrinsics: Intrinsics
    distortion: np.ndarray
    R: np.ndarray
    t: np.ndarray

    @property
    def K(self) -> np.ndarray:
        k = self.intrinsics
        return np.array([[k.fx, 0.0, k.cx], [0.0, k.fy, k.cy], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class Accelerometer:
    """``R_imu_depth`` (depth -> IMU coordinates), the ``bias`` (3,) m/s^2 and ``mixing`` (3, 3) at the
    calibration's temperature."""

    R_imu_depth: np.ndarray
    bias: np.ndarray
    mixing: np.ndarray

    def up_in_depth(self, raw_samples: np.ndarray) -> np.ndarray:
        """Gravity up in the depth camera's frame (unit (3,)) from raw accelerometer samples (N, 3) at rest: the
        accelerometer measures the support's push, which points up."""
        corrected = (np.asarray(raw_samples, dtype=np.float64) - self.bias) @ self.mixing.T
        up = self.R_imu_depth.T @ corrected.mean(axis=0)
        return up / np.linalg.norm(up)


def camera(calibration: dict, purpose: str) -> dict:
    """The calibration's camera entry for ``purpose`` ("Depth" or "PhotoVideo"); KeyError if absent."""
    for entry in calibration["CalibrationInformation"]["Cameras"]:
        if entry["Purpose"] == f"CALIBRATION_CameraPurpose{purpose}":
            return entry
    raise KeyError(f"no {purpose} camera in the calibration")


def depth_lens(calibration: dict, mode: str | None, size: tuple[int, int]) -> Lens:
    """The depth camera in ``mode`` (e.g. "NFOV_UNBINNED"; None: the mode whose output is ``size`` (w, h))."""
    entry = camera(calibration, "Depth")
    if mode not in DEPTH_MODES:
        mode = next((m for m, spec in DEPTH_MODES.items() if spec[2] == size), None)
        if mode is None:
            raise KeyError(f"no Azure Kinect depth mode gives {size[0]}x{size[1]} images")
    binned, offset, output = DEPTH_MODES[mode]
    return _lens(entry, binned, offset, output)


def color_lens(calibration: dict, size: tuple[int, int]) -> Lens:
    """The colour camera for images of ``size`` (w, h), from a 4:3 calibration (a legacy 16:9 one is made 4:3
    first, as the SDK does)."""
    entry = camera(calibration, "PhotoVideo")
    if size[1] not in COLOR_MODES or COLOR_MODES[size[1]][2] != size:
        raise KeyError(f"no Azure Kinect colour mode gives {size[0]}x{size[1]} images")
    params = np.array(entry["Intrinsics"]["ModelParameters"], dtype=np.float64)
    width, height = entry["SensorWidth"], entry["SensorHeight"]
    if width * 9 // 16 == height:  # legacy 16:9 calibration: unitized, shift by 384 rows of a 3072-row sensor
        params[1] = (params[1] * 2304 + 384) / 3072
        params[3] = params[3] * 2304 / 3072
    binned, offset, output = COLOR_MODES[size[1]]
    return _lens({**entry, "Intrinsics": {**entry["Intrinsics"], "ModelParameters": params.tolist()}},
                 binned, offset, output)


def _lens(entry: dict, binned, offset, output) -> Lens:
    p = np.array(entry["Intrinsics"]["ModelParameters"], dtype=np.float64)
    cx, cy = p[0] * binned[0] - offset[0] - 0.5, p[1] * binned[1] - offset[1] - 0.5
    fx, fy = p[2] * binned[0], p[3] * binned[1]
    distortion = np.array([p[4], p[5], p[13], p[12], p[6], p[7], p[8], p[9]])
    R, t = _rt(entry["Rt"])
    return Lens(Intrinsics(int(output[0]), int(output[1]), float(fx), float(fy), float(cx), float(cy)),
                distortion, R, t)


def accelerometer(calibration: dict) -> Accelerometer:
    """The accelerometer's extrinsics and intrinsics; KeyError if the calibration has none."""
    for entry in calibration["CalibrationInformation"].get("InertialSensors", []):
        if entry["SensorType"] == "CALIBRATION_InertialSensorType_Accelerometer":
            temperature = float(entry.get("TemperatureC", 0.0))
            powers = temperature ** np.arange(4)
            bias = np.array(entry["BiasTemperatureModel"], dtype=np.float64).reshape(3, 4) @ powers
            mixing = (np.array(entry["MixingMatrixTemperatureModel"], dtype=np.float64).reshape(9, 4) @ powers)
            R, _ = _rt(entry["Rt"])
            return Accelerometer(R, bias, mixing.reshape(3, 3))
    raise KeyError("no accelerometer in the calibration")


def imu_samples(block: bytes) -> list[tuple[float, np.ndarray]]:
    """(accelerometer time in s, raw acceleration (3,) m/s^2) per sample in an IMU block; ValueError if the block
    is not whole samples."""
    if len(block) % IMU_SAMPLE.size:
        raise ValueError(f"an IMU block of {len(block)} bytes is not whole {IMU_SAMPLE.size}-byte samples")
    out = []
    for offset in range(0, len(block), IMU_SAMPLE.size):
        acc_ns, ax, ay, az, *_ = IMU_SAMPLE.unpack_from(block, offset)
        out.append((acc_ns * 1e-9, np.array([ax, ay, az])))
    return out


def _rt(rt: dict) -> tuple[np.ndarray, np.ndarray]:
    return (np.array(rt["Rotation"], dtype=np.float64).reshape(3, 3),
            np.array(rt["Translation"], dtype=np.float64).reshape(3))
