"""The sensor's prior pose from what a user or an IMU knows: a position, a heading, and gravity's "up" measured in
the sensor frame. Sensor frames are OpenCV optical frames (x right, y down, z forward); world is z-up."""

from __future__ import annotations

import json
import math
import numbers
from pathlib import Path

import numpy as np

from bim2rdt.frames import rigid_problem
from bim2rdt.verify.errors import VerifyError

LEVEL_UP = np.array([0.0, -1.0, 0.0])
"""Gravity up in the frame of a level optical sensor: its -y axis."""
MAX_PRIOR_FILE_BYTES = 64 * 1024
"""A prior file holds one 4x4 matrix (under 1 kB written out in full); a larger one is refused unread."""
MAX_PRIOR_TRANSLATION_M = 1e6
"""A prior's translation beyond this (m, 1000 km) is refused: no building model spans it, and arithmetic on
coordinates near 1e308 overflows."""


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


def read_prior_file(path: str | Path) -> np.ndarray:
    """The prior pose of a ``--prior-file``: a JSON list of 4 lists of 4 numbers, ``T_world_sensor``.

    Its text is never echoed in an error (a file given by mistake may hold anything).

    Args:
        path: The JSON file.

    Returns:
        ``T_world_sensor``, a 4x4 rigid pose (:func:`bim2rdt.frames.rigid_problem`), metres.

    Raises:
        VerifyError: One line naming the file: unreadable, over :data:`MAX_PRIOR_FILE_BYTES`, not JSON, nested
            too deep, not 4 lists of 4 numbers, NaN or infinite, a translation over
            :data:`MAX_PRIOR_TRANSLATION_M`, or not rigid.
    """
    path = Path(path)
    where = f"--prior-file {path}"
    try:
        if path.stat().st_size > MAX_PRIOR_FILE_BYTES:
            raise VerifyError(f"{where}: {path.stat().st_size} bytes: too large for one 4x4 matrix")
        data = json.loads(path.read_bytes())
    except OSError as error:
        raise VerifyError(f"{where}: cannot read it ({error.strerror or type(error).__name__})") from None
    except RecursionError:
        raise VerifyError(f"{where}: nested too deep: expected a 4x4 matrix (a list of 4 lists of 4 numbers)") \
            from None
    except ValueError as error:  # JSONDecodeError, UnicodeDecodeError: position only, never the text
        at = f" at line {error.lineno} column {error.colno}" if isinstance(error, json.JSONDecodeError) else ""
        raise VerifyError(f"{where}: not valid JSON{at}") from None
    T = _matrix(data, where)
    problem = rigid_problem(T)
    if problem is not None:
        raise VerifyError(f"{where}: not a rigid transform T_world_sensor: {problem}")
    if np.abs(T[:3, 3]).max() > MAX_PRIOR_TRANSLATION_M:
        raise VerifyError(f"{where}: its translation is over {MAX_PRIOR_TRANSLATION_M:g} m: not a position in a "
                          "building (metres)")
    return T


def _matrix(data: object, where: str) -> np.ndarray:
    """A 4x4 float array from parsed JSON, checked element by element (no text of the file in the errors)."""
    if not (isinstance(data, list) and len(data) == 4 and all(isinstance(row, list) and len(row) == 4 for row in data)):
        raise VerifyError(f"{where}: expected a 4x4 matrix (a list of 4 lists of 4 numbers), got {_shape(data)}")
    values = [value for row in data for value in row]
    if any(isinstance(v, bool) or not isinstance(v, numbers.Real) for v in values):
        kinds = sorted({type(v).__name__ for v in values if isinstance(v, bool) or not isinstance(v, numbers.Real)})
        raise VerifyError(f"{where}: expected numbers in the 4x4 matrix, found {', '.join(kinds)}")
    T = np.array(values, dtype=np.float64).reshape(4, 4)
    if not np.all(np.isfinite(T)):
        raise VerifyError(f"{where}: {int((~np.isfinite(T)).sum())} entries are NaN or infinite: a pose is finite "
                          "numbers")
    return T


def _shape(data: object) -> str:
    """What a parsed JSON value is, in a few words (its type and lengths, never its text)."""
    if isinstance(data, list):
        inner = {len(row) if isinstance(row, list) else type(row).__name__ for row in data}
        return f"a list of {len(data)} items ({', '.join(map(str, sorted(inner, key=str)))})" if data else "[]"
    return f"a JSON {type(data).__name__}"
