"""The sensor's prior pose from what a user or an IMU knows: a position, a heading, and gravity's "up" measured in
the sensor frame. Sensor frames are OpenCV optical frames (x right, y down, z forward); world is z-up."""

from __future__ import annotations

import math

import numpy as np

from bim2rdt.verify.errors import VerifyError

LEVEL_UP = np.array([0.0, -1.0, 0.0])
"""Gravity up in the frame of a level optical sensor: its -y axis."""


def prior_pose(position: np.ndarray | tuple[float, float, float], yaw_deg: float,
               up_sensor: np.ndarray | tuple[float, float, float] | None = None) -> np.ndarray:
    """A sensor's pose from its position, heading and measured up.

    Args:
        position: The sensor's position in the world frame, metres.
        yaw_deg: The heading of the optical axis from world +x, degrees, counter-clockwise seen from above.
        up_sensor: Gravity up in the sensor's OpenCV optical frame (an IMU's); None means level (-y).

    Returns:
        ``T_world_sensor``, 4x4 sensor-to-world, tilted so that ``up_sensor`` maps onto world +z.

    Raises:
        VerifyError: Up is zero, not finite, or along the optical axis.
    """
    up = LEVEL_UP if up_sensor is None else np.asarray(up_sensor, dtype=np.float64)
    if up.shape != (3,) or not np.all(np.isfinite(up)) or np.linalg.norm(up) < 1e-9:
        raise VerifyError(f"up must be a finite non-zero vector in the sensor frame, got {np.asarray(up).tolist()}")
    up = up / np.linalg.norm(up)
    forward = np.array([0.0, 0.0, 1.0]) - up * up[2]  # the optical axis less its vertical part
    if np.linalg.norm(forward) < 1e-6:
        raise VerifyError("up lies along the optical axis: the sensor looks straight up or down, it has no heading")
    forward /= np.linalg.norm(forward)
    R_level_sensor = np.stack([forward, np.cross(up, forward), up])  # rows: heading, left, up in sensor coordinates
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    T = np.eye(4)
    T[:3, :3] = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ R_level_sensor
    T[:3, 3] = np.asarray(position, dtype=np.float64)
    return T


def heading_deg(T_world_sensor: np.ndarray) -> float:
    """The heading of a sensor's optical axis in the horizontal plane.

    Args:
        T_world_sensor: 4x4 sensor-to-world pose (OpenCV axes: z is the optical axis).

    Returns:
        Degrees from world +x, counter-clockwise seen from above.
    """
    return math.degrees(math.atan2(T_world_sensor[1, 2], T_world_sensor[0, 2]))


def levelled(T_world_sensor: np.ndarray, up_sensor: np.ndarray | tuple[float, float, float] | None) -> np.ndarray:
    """A pose with its position and heading kept and its roll and pitch from a measured up.

    Args:
        T_world_sensor: 4x4 sensor-to-world pose, metres.
        up_sensor: Gravity up in the sensor frame (an IMU's); None means level.

    Returns:
        The levelled ``T_world_sensor``.

    Raises:
        VerifyError: Up is zero, not finite, or along the optical axis.
    """
    return prior_pose(T_world_sensor[:3, 3], heading_deg(T_world_sensor), up_sensor)
