"""Depth image -> camera-frame points: a regular pixel grid (every ``stride``-th pixel), valid returns in range.

A grid, not features: walls and slabs are textureless, and what pins a pose on them is their surface, which
every depth pixel samples. Camera frame is OpenCV's (x right, y down, z forward), metres.
"""

from __future__ import annotations

import numpy as np

from bim2rdt.perception.frame import Frame


def depth_points(frame: Frame, stride: int, min_range: float, max_range: float) -> np.ndarray:
    """Camera-frame points (N, 3) of every ``stride``-th pixel with a depth in [min_range, max_range] m."""
    depth = frame.depth[::stride, ::stride]
    v, u = np.mgrid[0:frame.depth.shape[0]:stride, 0:frame.depth.shape[1]:stride]
    keep = np.isfinite(depth) & (depth >= min_range) & (depth <= max_range)
    uv = np.stack([u[keep], v[keep]], axis=1).astype(np.float64)
    return frame.intrinsics.backproject(uv, depth[keep].astype(np.float64))
