"""Depth calibration: an inverse-depth offset linear across the image (a structured-light camera's disparity bias).

For a camera-frame point p (metres), the corrected point is ``p_true = p / (1 - g . p)``. The correction scales p
along its own ray, so on a depth image it changes only the depth: with the pixel's ray r (z = 1) and depth z,
``z_true = z / (1 - z g . r)``. A pixel where ``1 - g . p <= 0`` has no true point (it would lie at or beyond
infinity) and becomes no return (NaN).
"""

from __future__ import annotations

import numpy as np

from bim2rdt.perception import Intrinsics


def correction_vector(g) -> np.ndarray:
    """``g`` as a finite (3,) float64 (1/m), or ValueError naming what is wrong."""
    try:
        g = np.asarray(g, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"depth_correction must be three numbers (gx, gy, gz) in 1/m, got {g!r}") from None
    if g.shape != (3,) or not np.all(np.isfinite(g)):
        raise ValueError(f"depth_correction must be three finite numbers (gx, gy, gz) in 1/m, got {g.tolist()}")
    return g


def correct_points(points_camera: np.ndarray, g: np.ndarray | list[float] | tuple[float, ...]) -> np.ndarray:
    """Apply the depth correction ``p / (1 - g . p)`` to camera-frame points.

    Args:
        points_camera: (N,3) points in the camera's OpenCV optical frame (x right, y down, z forward), metres.
        g: The correction vector (gx, gy, gz), 1/m.

    Returns:
        (N,3) corrected points, metres; NaN rows where ``1 - g . p <= 0`` (no true point).

    Raises:
        ValueError: ``g`` is not three finite numbers.
    """
    points = np.asarray(points_camera, dtype=np.float64)
    denominator = 1.0 - points @ correction_vector(g)
    with np.errstate(divide="ignore", invalid="ignore"):
        corrected = points / denominator[:, None]
    corrected[~(denominator > 0)] = np.nan
    return corrected


def correct_depth(depth: np.ndarray, intrinsics: Intrinsics,
                  g: np.ndarray | list[float] | tuple[float, ...]) -> np.ndarray:
    """Apply the depth correction to a depth image: ``z / (1 - z g . r)`` per pixel ray r (z = 1).

    Args:
        depth: (H,W) depth along the optical axis, metres; 0 or NaN is no return.
        intrinsics: The depth camera's pinhole intrinsics (the pixel rays).
        g: The correction vector (gx, gy, gz), 1/m, in the camera's OpenCV optical frame.

    Returns:
        (H,W) float32 corrected depth, metres; no return stays no return, and a pixel with no true point is NaN.

    Raises:
        ValueError: ``g`` is not three finite numbers.
    """
    depth = np.asarray(depth, dtype=np.float64)
    g = correction_vector(g)
    g_dot_ray = intrinsics.pixel_rays() @ g
    denominator = 1.0 - depth * g_dot_ray
    with np.errstate(divide="ignore", invalid="ignore"):
        corrected = np.where(denominator > 0, depth / denominator, np.nan)
    corrected[~(depth > 0)] = depth[~(depth > 0)]
    return corrected.astype(np.float32)
