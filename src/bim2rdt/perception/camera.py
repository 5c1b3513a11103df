"""The pinhole RGB-D camera: intrinsics, pixel rays, and back-projection of pixels with depth to 3-D points.

Camera frame is OpenCV's: x right, y down, z forward (metres). ``T_world_camera`` maps camera to world.
Depth is the z coordinate in the camera frame (what RGB-D sensors report), not the range along the ray.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bim2rdt import exact
from bim2rdt.errors import Bim2RdtError


class CameraError(Bim2RdtError):
    """A camera pose that cannot be built (its image axes are undefined)."""


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics in pixels; the defaults are a Kinect/RealSense-class 640x480 VGA depth camera."""

    width: int = 640
    height: int = 480
    fx: float = 525.0
    fy: float = 525.0
    cx: float = 319.5
    cy: float = 239.5

    def __post_init__(self) -> None:
        """Refuse what no camera has, where the intrinsics are made (else a zero, negative or non-finite focal
        length surfaces much later as "the frame sees no permanent element")."""
        for name in ("width", "height"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value <= 0:
                raise CameraError(f"intrinsics: {name} must be a positive whole number of pixels, got {value!r}")
        for name in ("fx", "fy", "cx", "cy"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating) \
                    or not math.isfinite(value):
                raise CameraError(f"intrinsics: {name} must be a finite number of pixels, got {value!r}")
        for name in ("fx", "fy"):
            if getattr(self, name) <= 0:
                raise CameraError(f"intrinsics: {name} must be positive (a focal length in pixels), got "
                                  f"{getattr(self, name)!r}")

    def pixel_rays(self) -> np.ndarray:
        """Camera-frame ray directions with z = 1 for every pixel, (H, W, 3), row-major (v, u)."""
        u, v = np.meshgrid(np.arange(self.width), np.arange(self.height))
        return np.stack([(u - self.cx) / self.fx, (v - self.cy) / self.fy, np.ones(u.shape)], axis=-1)

    def backproject(self, uv: np.ndarray, depth: np.ndarray) -> np.ndarray:
        """Pixels (N, 2) as (u, v) with depths (N,) in metres -> camera-frame points (N, 3)."""
        x = (uv[:, 0] - self.cx) / self.fx * depth
        y = (uv[:, 1] - self.cy) / self.fy * depth
        return np.stack([x, y, depth], axis=1)


def look_at(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """T_world_camera of a camera at ``eye`` looking at ``target`` with world ``up`` appearing up in the image."""
    eye, target, up = (np.asarray(v, dtype=np.float64) for v in (eye, target, up))
    forward = target - eye
    if exact.norm(forward) < 1e-9:
        raise CameraError(f"look_at: eye and target coincide at {eye.tolist()}")
    forward /= exact.norm(forward)
    right = np.cross(forward, up)
    if exact.norm(right) < 1e-9:
        raise CameraError(f"look_at: the view direction {forward.tolist()} is parallel to up; the image has no "
                          "horizon to align")
    right /= exact.norm(right)
    down = np.cross(forward, right)
    T = np.eye(4)
    T[:3, :3] = np.stack([right, down, forward], axis=1)
    T[:3, 3] = eye
    return T
