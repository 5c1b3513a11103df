"""Frame-to-frame odometry for a recording without poses: the motion between two consecutive depth frames by
point-to-plane ICP (6 DoF, Gauss-Newton, Huber weights), the tracked prior's step between BIM fixes.

Measured against Open3D's RGB-D odometry (hybrid term) in ``bench localization``'s global section; decision 0031
gives the figures.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from bim2rdt.localization.cloud import pca_normals, voxel_means


@dataclass(frozen=True)
class Odometry:
    """``T_previous_current`` (4, 4): the current sensor pose in the previous sensor's frame; ``fitness`` the share
    of the current points within ``max_distance`` of the previous surface; ``rmse`` their residual, m."""

    T_previous_current: np.ndarray
    fitness: float
    rmse: float


def icp_odometry(previous: np.ndarray, current: np.ndarray, voxel: float = 0.05, max_distance: float = 0.15,
                 iterations: int = 30, huber: float = 0.02, init: np.ndarray | None = None) -> Odometry:
    """The motion between two clouds of one moving sensor by point-to-plane ICP.

    Args:
        previous: The previous frame's points (N, 3), its sensor frame, metres (NaN rows ignored).
        current: The current frame's points (M, 3), its sensor frame, metres.
        voxel: Both clouds are thinned to one point per cube of this size, m.
        max_distance: Pairs farther apart than this are not matched, m.
        iterations: Gauss-Newton steps at most.
        huber: Huber scale of the point-to-plane residuals, m.
        init: A first guess of ``T_previous_current`` (identity when None).

    Returns:
        The :class:`Odometry`; fitness 0 when either cloud has fewer than 30 points.
    """
    T = np.eye(4) if init is None else np.asarray(init, dtype=np.float64).copy()
    target, source = _thinned(previous, voxel), _thinned(current, voxel)
    if len(target) < 30 or len(source) < 30:
        return Odometry(T, 0.0, float("inf"))
    normals = pca_normals(target, 12)
    flat = np.isfinite(normals[:, 0])
    target, normals = target[flat], normals[flat]
    tree = cKDTree(target)
    for _ in range(iterations):
        moved = source @ T[:3, :3].T + T[:3, 3]
        distance, index = tree.query(moved, distance_upper_bound=max_distance)
        paired = np.isfinite(distance)
        if paired.sum() < 12:
            break
        step = _gauss_newton(moved[paired], target[index[paired]], normals[index[paired]], huber)
        T = step @ T
        if np.linalg.norm(step[:3, 3]) < 1e-5 and np.arccos(min(1.0, (np.trace(step[:3, :3]) - 1) / 2)) < 1e-5:
            break
    moved = source @ T[:3, :3].T + T[:3, 3]
    distance, index = tree.query(moved, distance_upper_bound=max_distance / 3)
    paired = np.isfinite(distance)
    rmse = float(np.sqrt(np.mean(distance[paired] ** 2))) if paired.any() else float("inf")
    return Odometry(T, float(paired.mean()), rmse)


def _thinned(points: np.ndarray, voxel: float) -> np.ndarray:
    points = np.asarray(points, dtype=np.float64)
    points = points[np.all(np.isfinite(points), axis=1)]
    points = points[np.linalg.norm(points, axis=1) > 0.1]
    return voxel_means(points, voxel) if len(points) else points


def _gauss_newton(source: np.ndarray, target: np.ndarray, normals: np.ndarray, huber: float) -> np.ndarray:
    """One weighted point-to-plane step: the small rigid motion (4, 4) that brings ``source`` onto the planes."""
    residual = np.einsum("ni,ni->n", source - target, normals)
    weight = np.where(np.abs(residual) <= huber, 1.0, huber / np.maximum(np.abs(residual), 1e-12))
    J = np.hstack([np.cross(source, normals), normals])
    H = (J * weight[:, None]).T @ J
    g = (J * weight[:, None]).T @ residual
    try:
        x = -np.linalg.solve(H + 1e-9 * np.eye(6), g)
    except np.linalg.LinAlgError:
        return np.eye(4)
    step = np.eye(4)
    step[:3, :3] = _rotation(x[:3])
    step[:3, 3] = x[3:]
    return step


def _rotation(w: np.ndarray) -> np.ndarray:
    angle = np.linalg.norm(w)
    if angle < 1e-12:
        return np.eye(3)
    k = w / angle
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K
