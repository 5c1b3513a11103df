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


def depth_grid(frame: Frame, stride: int, min_range: float, max_range: float) -> np.ndarray:
    """Camera-frame points on the ``stride``-pixel grid, (H', W', 3), NaN where the depth is out of range."""
    depth = frame.depth[::stride, ::stride].astype(np.float64)
    depth = np.where(np.isfinite(depth) & (depth >= min_range) & (depth <= max_range), depth, np.nan)
    v, u = np.mgrid[0:frame.depth.shape[0]:stride, 0:frame.depth.shape[1]:stride]
    intr = frame.intrinsics
    return np.stack([(u - intr.cx) / intr.fx * depth, (v - intr.cy) / intr.fy * depth, depth], axis=-1)


def grid_normals(grid: np.ndarray) -> np.ndarray:
    """Unit normals (H', W', 3) of an organised point grid from central differences (NaN at borders, holes and
    depth jumps), turned towards the camera."""
    normals = np.full(grid.shape, np.nan)
    across = grid[1:-1, 2:] - grid[1:-1, :-2]
    down = grid[2:, 1:-1] - grid[:-2, 1:-1]
    n = np.cross(across, down)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    facing = np.einsum("hwi,hwi->hw", n, grid[1:-1, 1:-1]) > 0
    normals[1:-1, 1:-1] = np.where(facing[..., None], -n, n)
    return normals
