"""Gravity and height for a search without a prior: the sensor's tilt and its height above the floor, from the
data alone (or an IMU).

Up is the source's IMU reading when it has one (``given``/``imu``); else the dominant floor plane: the largest
flat patch whose normal lies within ``floor_cone_deg`` of the sensor's usual up (a camera's -y, a scanner's +z)
and that lies lowest below the sensor (a desk top is nearer, the floor is the lowest surface that many points
share). When there is none around the usual up, the other axes are tried (a scan written y-up), a floor
accepted only with the sensor 0.1-3 m above it. The height is the sensor's distance to that plane along up,
so the search is left with x, y and yaw. A wall within 0.1-3 m can pass for a floor along a scan's usual
up: :func:`other_floors` gives the floors along the other axes, for the search to try when the first gives no
pose.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bim2rdt.localization.cloud import ScanPoints
from bim2rdt.localization.errors import LocalizationError

CAMERA_UP = np.array([0.0, -1.0, 0.0])
"""Gravity up of a level optical sensor (x right, y down, z forward)."""
SCANNER_UP = np.array([0.0, 0.0, 1.0])
"""Gravity up of a scanner in its own frame (z up, as E57, LAS and PLY scans are written)."""


@dataclass(frozen=True)
class Levelled:
    """The sensor's tilt and height: ``R_level_sensor`` (3, 3) turns sensor-frame vectors into a frame whose z is
    world up (its heading arbitrary: the search finds it), ``height`` the sensor above the floor (m), ``up`` the
    unit up in the sensor frame, and ``gravity``: where up came from (``"given"``, ``"imu"`` or ``"floor"``)."""

    R_level_sensor: np.ndarray
    height: float
    up: np.ndarray
    gravity: str
    floor_points: int


def level(scan: ScanPoints, up: np.ndarray | None, gravity: str, default_up: np.ndarray, cone_deg: float,
          min_floor_points: int) -> Levelled:
    """The tilt from ``up`` (sensor frame; None: the floor plane's normal) and the height from the floor.

    Args:
        scan: The thinned points and normals, sensor frame, metres.
        up: Gravity up in the sensor frame (an IMU's), or None to take the floor's normal.
        gravity: Where ``up`` came from (``"given"`` or ``"imu"``); ignored when ``up`` is None.
        default_up: The sensor's usual up (sensor frame), the centre of the cone the floor's normal is sought in.
        cone_deg: The floor's normal lies within this many degrees of ``default_up`` (or of ``up`` when given).
        min_floor_points: Fewer thinned points on the floor than this, and there is no floor in view.

    Returns:
        The :class:`Levelled` sensor.

    Raises:
        LocalizationError: No floor in view (the height is unknown), or a zero or non-finite ``up``.
    """
    if up is not None:
        up = np.asarray(up, dtype=np.float64)
        if up.shape != (3,) or not np.all(np.isfinite(up)) or np.linalg.norm(up) < 1e-9:
            raise LocalizationError(f"up must be a finite non-zero 3-vector in the sensor frame, got {up.tolist()}")
        up = up / np.linalg.norm(up)
    if up is not None:
        _, height, count = _floor(scan, up, min(cone_deg, 10.0), min_floor_points)
        height = float(np.median(-(scan.points[_on_floor(scan, up, height)] @ up)))
        return Levelled(level_rotation(up), height, up, gravity, count)
    first_error = None
    for axis in _axes(default_up):
        try:
            normal, height, count = _floor(scan, axis, cone_deg, min_floor_points)
        except LocalizationError as error:
            first_error = first_error or error
            continue
        if MIN_HEIGHT <= height <= MAX_HEIGHT:
            return Levelled(level_rotation(normal), height, normal, "floor", count)
    raise first_error or _no_floor(0, min_floor_points)


def other_floors(scan: ScanPoints, taken: Levelled, cone_deg: float, min_floor_points: int) -> list[Levelled]:
    """The floors found along the axes other than ``taken``'s up, each with the sensor 0.1-3 m above it: where a
    cloud written in unknown axes might stand instead (the search lets the BIM tell them apart).

    Args:
        scan: The thinned points and normals, sensor frame, metres.
        taken: The levelling :func:`level` took.
        cone_deg: A floor's normal lies within this many degrees of its axis.
        min_floor_points: Fewer thinned points on a floor than this, and it is not one.

    Returns:
        The other levellings, each more than 45 degrees from ``taken`` and from one another.
    """
    found: list[Levelled] = []
    for axis in _axes(taken.up):
        if any(float(axis @ f.up) > np.cos(np.pi / 4) for f in (taken, *found)):
            continue
        try:
            normal, height, count = _floor(scan, axis, cone_deg, min_floor_points)
        except LocalizationError:
            continue
        apart = all(float(normal @ f.up) < np.cos(np.pi / 4) for f in (taken, *found))
        if MIN_HEIGHT <= height <= MAX_HEIGHT and apart:
            found.append(Levelled(level_rotation(normal), height, normal, "floor", count))
    return found


MIN_HEIGHT, MAX_HEIGHT = 0.1, 3.0
"""A floor found along another axis than the sensor's usual up is taken only with the sensor this high above it
(m): a scan written y-up, or in a camera's axes, still finds its floor; a wall's plane does not pass as one."""


def _axes(default_up: np.ndarray) -> list[np.ndarray]:
    """The sensor's usual up, then the other five axis directions (a scan written y-up or in a camera's axes)."""
    others = [np.array(v, dtype=np.float64) for v in ((0, 0, 1), (0, -1, 0), (0, 1, 0), (0, 0, -1), (1, 0, 0),
                                                      (-1, 0, 0))]
    return [default_up] + [v for v in others if not np.allclose(v, default_up)]


def level_rotation(up: np.ndarray) -> np.ndarray:
    """A rotation (3, 3) taking the sensor's ``up`` (unit, sensor frame) to +z; its x is the sensor's z (a
    camera's optical axis) made horizontal, or its x where z is near vertical (a scanner)."""
    forward = np.array([0.0, 0.0, 1.0]) if abs(up[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    forward = forward - up * (forward @ up)
    forward /= np.linalg.norm(forward)
    return np.stack([forward, np.cross(up, forward), up])


def _floor(scan: ScanPoints, axis: np.ndarray, cone_deg: float, min_points: int) -> tuple[np.ndarray, float, int]:
    """(unit normal, the sensor's height above it, points on it) of the lowest well-supported plane whose normal
    is within ``cone_deg`` of ``axis``; refined by a least-squares fit of its points."""
    normals = scan.normals
    flat = np.isfinite(normals[:, 0])
    upward = np.zeros(len(normals), bool)
    upward[flat] = normals[flat] @ axis >= np.cos(np.deg2rad(cone_deg))
    if upward.sum() < min_points:
        raise _no_floor(int(upward.sum()), min_points)
    normal = _mean_unit(normals[upward])
    for _ in range(3):
        below = -(scan.points @ normal)  # each point's depth below the sensor along -up
        heights = below[upward]
        level_h = _lowest_support(heights, min_points)
        if level_h is None:
            raise _no_floor(int(upward.sum()), min_points)
        on = upward & (np.abs(below - level_h) < 0.06)
        normal = _plane_normal(scan.points[on], normal)
    below = -(scan.points @ normal)
    on = upward & (np.abs(below - level_h) < 0.04)
    return normal, float(np.median(below[on])), int(on.sum())


def _lowest_support(heights: np.ndarray, min_points: int) -> float | None:
    """The largest depth below the sensor (m) where at least ``min_points`` heights gather within 5 cm, the mode
    of that bin: the floor, not a table top above it."""
    bins = np.arange(heights.min() - 0.05, heights.max() + 0.1, 0.05)
    counts, edges = np.histogram(heights, bins)
    paired = counts[:-1] + counts[1:] if len(counts) > 1 else counts
    supported = np.nonzero(paired >= min_points)[0]
    if len(supported) == 0:
        return None
    k = supported[-1]
    inside = heights[(heights >= edges[k]) & (heights < edges[min(k + 2, len(edges) - 1)])]
    return float(np.median(inside))


def _on_floor(scan: ScanPoints, up: np.ndarray, height: float) -> np.ndarray:
    return np.abs(-(scan.points @ up) - height) < 0.05


def _plane_normal(points: np.ndarray, near: np.ndarray) -> np.ndarray:
    """The least-squares plane's unit normal of ``points``, turned towards ``near``."""
    if len(points) < 3:
        return near
    _, _, vt = np.linalg.svd(points - points.mean(axis=0), full_matrices=False)
    normal = vt[-1]
    return normal if normal @ near >= 0 else -normal


def _mean_unit(vectors: np.ndarray) -> np.ndarray:
    mean = vectors.mean(axis=0)
    return mean / np.linalg.norm(mean)


def _no_floor(found: int, need: int) -> LocalizationError:
    return LocalizationError(f"no floor in view ({found} points face up, need {need}): without a prior the sensor's "
                             "height comes from the floor; give --prior, or a frame that sees the floor")
