"""Rotation helpers, batched over a leading axis: skew matrices, the exponential map, angles, tilt."""

from __future__ import annotations

import numpy as np

from bim2rdt import exact
from bim2rdt.frames import UP


def skew(v: np.ndarray) -> np.ndarray:
    """(..., 3) -> (..., 3, 3) with skew(a) @ b == cross(a, b)."""
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def exp_so3(omega: np.ndarray) -> np.ndarray:
    """Rodrigues: rotation vectors (..., 3) in radians -> rotation matrices (..., 3, 3)."""
    theta = exact.norm(omega)[..., None, None]
    K = skew(omega)
    small = theta < 1e-12
    safe = np.where(small, 1.0, theta)
    a = np.where(small, 1.0, np.sin(safe) / safe)
    b = np.where(small, 0.5, (1.0 - np.cos(safe)) / safe**2)
    return np.eye(3) + a * K + b * exact.matmul(K, K)


def axis_angle(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotations by ``angle`` (..., radians) about unit ``axis`` (..., 3)."""
    return exp_so3(np.asarray(axis) * np.asarray(angle)[..., None])


def rotation_angle(R: np.ndarray) -> np.ndarray:
    """Geodesic angle of rotations (..., 3, 3), radians in [0, pi]."""
    cos = (np.trace(R, axis1=-2, axis2=-1) - 1.0) / 2.0
    return np.arccos(np.clip(cos, -1.0, 1.0))


def tilt_angle(R: np.ndarray, up: np.ndarray = UP) -> np.ndarray:
    """Angle between the body's upright axis (+z) mapped to the world and the world ``up``, radians."""
    cos = np.einsum("...i,i->...", R[..., :, 2], up)
    return np.arccos(np.clip(cos, -1.0, 1.0))


def invert_poses(T: np.ndarray) -> np.ndarray:
    """Inverse of rigid poses.

    Args:
        T: (..., 4, 4) rigid poses.

    Returns:
        (..., 4, 4) their inverses.
    """
    R_t = np.swapaxes(T[..., :3, :3], -1, -2)
    out = np.zeros_like(T)
    out[..., :3, :3] = R_t
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", R_t, T[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out
