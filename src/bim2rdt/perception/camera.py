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
        """The ray of every pixel in the camera's OpenCV optical frame (x right, y down, z forward).

        Returns:
            (H,W,3) ray directions with z = 1, indexed [v, u].
        """
        u, v = np.meshgrid(np.arange(self.width), np.arange(self.height))
        return np.stack([(u - self.cx) / self.fx, (v - self.cy) / self.fy, np.ones(u.shape)], axis=-1)

    def backproject(self, uv: np.ndarray, depth: np.ndarray) -> np.ndarray:
        """Lift pixels with depths to 3D points in the camera's OpenCV optical frame (x right, y down, z forward).

        Args:
            uv: (N,2) pixel coordinates (u column, v row).
            depth: (N,) depths along the optical axis (z), metres.

        Returns:
            (N,3) points in the camera frame, metres.
        """
        x = (uv[:, 0] - self.cx) / self.fx * depth
        y = (uv[:, 1] - self.cy) / self.fy * depth
        return np.stack([x, y, depth], axis=1)


def look_at(eye: np.ndarray | tuple[float, float, float], target: np.ndarray | tuple[float, float, float],
            up: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 1.0)) -> np.ndarray:
    """The pose of a camera at ``eye`` looking at ``target`` with world ``up`` appearing up in the image.

    Args:
        eye: The camera centre in the world frame, metres.
        target: A world point on the optical axis, metres.
        up: The world direction that points up in the image (z-up world: +z).

    Returns:
        ``T_world_camera``, 4x4 camera-to-world; the camera axes are OpenCV's (x right, y down, z forward).

    Raises:
        CameraError: ``eye`` and ``target`` coincide, or the view direction is parallel to ``up``.
    """
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
