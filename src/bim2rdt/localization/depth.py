"""Depth image -> camera-frame points: a regular pixel grid (every ``stride``-th pixel), valid returns in range.

A grid, not features: walls and slabs are textureless, and what pins a pose on them is their surface, which
every depth pixel samples. Camera frame is OpenCV's (x right, y down, z forward), metres.
"""

from __future__ import annotations

import numpy as np

from bim2rdt.perception import Frame


def depth_grid(frame: Frame, stride: int = 1, min_range: float = 0.0, max_range: float = np.inf) -> np.ndarray:
    """Camera-frame points on the ``stride``-pixel grid, (H', W', 3) metres, NaN where there is no return (a
    depth that is not finite or not positive) or it lies outside [min_range, max_range]: the one place depth
    pixels become points (the pinhole of ``frame.intrinsics``).

    Args:
        frame: The RGB-D frame (depth in metres).
        stride: Every ``stride``-th row and column.
        min_range: Nearest depth kept, metres.
        max_range: Farthest depth kept, metres.

    Returns:
        The organised points.
    """
    depth = frame.depth[::stride, ::stride].astype(np.float64)
    keep = np.isfinite(depth) & (depth > 0) & (depth >= min_range) & (depth <= max_range)
    depth = np.where(keep, depth, np.nan)
    v, u = np.mgrid[0:frame.depth.shape[0]:stride, 0:frame.depth.shape[1]:stride]
    intr = frame.intrinsics
    return np.stack([(u - intr.cx) / intr.fx * depth, (v - intr.cy) / intr.fy * depth, depth], axis=-1)


def depth_points(frame: Frame, stride: int = 1, min_range: float = 0.0, max_range: float = np.inf) -> np.ndarray:
    """The returns of :func:`depth_grid` as a list (N, 3), row by row: with the defaults, every valid pixel.

    Args:
        frame: The RGB-D frame (depth in metres).
        stride: Every ``stride``-th row and column.
        min_range: Nearest depth kept, metres.
        max_range: Farthest depth kept, metres.

    Returns:
        Camera-frame points, metres.
    """
    grid = depth_grid(frame, stride, min_range, max_range)
    return grid[np.isfinite(grid[..., 2])]


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
