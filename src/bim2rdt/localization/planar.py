"""4-DoF camera poses: (x, y, z, yaw) plus the tilt the IMU measures, and odometry increments between them.

World is z-up. A camera pose T_world_camera splits into a heading ``yaw`` (the direction of the camera's optical
axis in the horizontal plane, radians from world x, counter-clockwise) and a tilt ``R_level_camera`` that holds
roll and pitch: T = Rz(yaw) @ R_level_camera, at (x, y, z). Odometry moves the heading frame: an increment
(forward, left, up, turn) is a shift in the frame turned by the current yaw, then a turn.
"""

from __future__ import annotations

import numpy as np

STATE = ("x", "y", "z", "yaw")
"""The filter's state, metres and radians."""


def rz(yaw: float) -> np.ndarray:
    """3x3 rotation about world z by ``yaw`` radians."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def wrap(angle: np.ndarray | float) -> np.ndarray | float:
    """Angle(s) wrapped to [-pi, pi)."""
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def heading(T_world_camera: np.ndarray) -> float:
    """The camera's yaw: its optical axis (camera z) in the horizontal plane, radians."""
    forward = T_world_camera[:3, 2]
    return float(np.arctan2(forward[1], forward[0]))


def to_planar(T_world_camera: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Split a camera pose into a planar state and a tilt.

    Args:
        T_world_camera: (4, 4) the camera pose, metres, world z-up.

    Returns:
        The state, (4,) x, y, z (m) and yaw (radians, the optical axis's heading from world x), and the tilt
            R_level_camera, (3, 3) roll and pitch, so that T = Rz(yaw) @ R_level_camera.
    """
    yaw = heading(T_world_camera)
    return np.r_[T_world_camera[:3, 3], yaw], rz(-yaw) @ T_world_camera[:3, :3]


def from_planar(state: np.ndarray, R_level_camera: np.ndarray) -> np.ndarray:
    """Join a planar state and a tilt into a camera pose (the inverse of :func:`to_planar`).

    Args:
        state: (4,) x, y, z (m) and yaw (radians).
        R_level_camera: (3, 3) the tilt (roll and pitch).

    Returns:
        T_world_camera, (4, 4): Rz(yaw) @ R_level_camera at (x, y, z).
    """
    T = np.eye(4)
    T[:3, :3] = rz(float(state[3])) @ R_level_camera
    T[:3, 3] = state[:3]
    return T


def compose(state: np.ndarray, increment: np.ndarray) -> np.ndarray:
    """The state after an odometry ``increment`` (forward, left, up m, turn rad) in its heading frame."""
    x, y, z, yaw = state
    c, s = np.cos(yaw), np.sin(yaw)
    dx, dy, dz, dyaw = increment
    return np.array([x + c * dx - s * dy, y + s * dx + c * dy, z + dz, float(wrap(yaw + dyaw))])


def between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The odometry increment that takes state ``a`` to state ``b`` (the inverse of :func:`compose`).

    Args:
        a: (4,) the state before: x, y, z (m) and yaw (radians).
        b: (4,) the state after, likewise.

    Returns:
        (4,) forward, left, up (m, in the heading frame of ``a``) and turn (radians, wrapped to [-pi, pi)).
    """
    c, s = np.cos(a[3]), np.sin(a[3])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return np.array([c * dx + s * dy, -s * dx + c * dy, b[2] - a[2], float(wrap(b[3] - a[3]))])
