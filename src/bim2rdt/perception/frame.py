"""One RGB-D frame as a robot sends it: colour, depth, the camera's intrinsics and where the camera was.

Frames are OpenCV camera frames (x right, y down, z forward). Depth is metres along the camera z axis, with 0 or
NaN where the sensor had no return. ``T_world_camera`` (4x4) maps camera to world coordinates (world z-up,
metres). A frame is checked once, where it enters, so the stages after it can trust its shapes and units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bim2rdt.perception.camera import Intrinsics
from bim2rdt.perception.errors import PerceptionError

MAX_DEPTH_MEDIAN = 100.0
"""A median depth above this (m) is almost surely millimetres: no site RGB-D camera ranges 100 m."""


@dataclass(frozen=True)
class Frame:
    """``rgb`` (H, W, 3) uint8, ``depth`` (H, W) float32 metres (0 or NaN = no return), ``intrinsics`` and
    ``T_world_camera`` (4, 4). Raises :class:`PerceptionError` on shapes that disagree, a depth that looks like
    millimetres, or a pose that is not a finite rigid transform."""

    rgb: np.ndarray
    depth: np.ndarray
    intrinsics: Intrinsics
    T_world_camera: np.ndarray

    def __post_init__(self) -> None:
        rgb, depth = np.asarray(self.rgb), np.asarray(self.depth, dtype=np.float32)
        size = (self.intrinsics.height, self.intrinsics.width)
        if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.shape[:2] != size:
            raise PerceptionError(f"frame: rgb has shape {rgb.shape}, the intrinsics say ({size[0]}, {size[1]}, 3)")
        if rgb.dtype != np.uint8:
            raise PerceptionError(f"frame: rgb must be uint8, got {rgb.dtype}")
        if depth.shape != size:
            raise PerceptionError(f"frame: depth has shape {depth.shape}, the intrinsics say {size}")
        object.__setattr__(self, "depth", depth)
        object.__setattr__(self, "T_world_camera", _rigid(self.T_world_camera))
        valid = depth[np.isfinite(depth) & (depth > 0)]
        if valid.size and float(np.median(valid)) > MAX_DEPTH_MEDIAN:
            raise PerceptionError(f"frame: median depth {float(np.median(valid)):.0f} looks like millimetres; "
                                  "depth must be metres")

    @property
    def gray(self) -> np.ndarray:
        """(H, W) uint8 luminance (ITU-R BT.601), what the corner detector reads."""
        weights = np.array([0.299, 0.587, 0.114])
        return np.clip(self.rgb @ weights + 0.5, 0, 255).astype(np.uint8)

    @property
    def valid_depth(self) -> np.ndarray:
        """(H, W) bool: pixels with a finite, positive depth return."""
        return np.isfinite(self.depth) & (self.depth > 0)


def _rigid(T) -> np.ndarray:
    T = np.asarray(T, dtype=np.float64)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise PerceptionError(f"frame: T_world_camera must be a finite 4x4 matrix (shape {T.shape})")
    R = T[:3, :3]
    if np.abs(R @ R.T - np.eye(3)).max() > 1e-4 or np.linalg.det(R) < 0 or np.abs(T[3] - [0, 0, 0, 1]).max() > 1e-9:
        raise PerceptionError("frame: T_world_camera is not a rigid transform (rotation not orthonormal, or last row "
                              "not 0 0 0 1)")
    return T
