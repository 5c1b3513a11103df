"""Where the robot stands to look at each object, and in which order it visits them."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from bim2rdt.mission.config import MissionConfig
from bim2rdt.mission.records import Target
from bim2rdt.perception import look_at

SAME_EXTENT = 1e-6
"""Plan extents closer than this (m) are equal: a round object's x and y extents differ only in the last bits,
which differ between machines (BLAS kernels), and must not pick its "long side" differently on each."""


def nearly(value: float, decimals: int = 9) -> float:
    """``value`` rounded to ``decimals``: a sort key that keeps near-ties (last-bit noise, which differs between
    machines) in their given order, as exact ties are."""
    return round(value, decimals)


def plan_stations(targets: Sequence[Target], start_xy: Sequence[float], config: MissionConfig) -> list[np.ndarray]:
    """One camera pose per target, in nearest-neighbour order from ``start_xy``. Each looks at its object
    obliquely across its long side (35 degrees off broadside: an end-on view of a beam cannot tell where along
    its length it lies), from the side facing the other targets, far enough back for the whole object.

    Args:
        targets: The BIM objects to look at.
        start_xy: World (x, y) of the start, metres.
        config: Standoff and camera height.

    Returns:
        ``T_world_camera`` (4x4, metres) per target, in visiting order.
    """
    centre = np.mean([t.placement[:2, 3] for t in targets], axis=0)
    poses = []
    for target in targets:
        view = view_directions(target, centre - target.placement[:2, 3])[0]
        poses.append(station_pose(target, view, config))
    return _tour(poses, np.asarray(start_xy, dtype=float))


def station_pose(target: Target, view: np.ndarray, config: MissionConfig, scale: float = 1.0) -> np.ndarray:
    """T_world_camera looking at ``target`` from the unit (2,) direction ``view`` (object to camera), far enough
    back for the whole object (times ``scale``)."""
    where = target.placement[:2, 3]
    standoff = scale * max(config.standoff, 1.2 * float(np.max(target.mesh_body.extents[:2])))
    return look_at(np.r_[where + standoff * view, config.camera_height], np.r_[where, 0.35])


def view_directions(target: Target, towards: np.ndarray) -> list[np.ndarray]:
    """Unit (2,) directions from the object to its camera, best first: broadside +-35 degrees, the one nearest
    ``towards`` first, then the other three."""
    extents = target.mesh_body.extents
    round_in_plan = abs(extents[0] - extents[1]) <= SAME_EXTENT  # a drum, a cone: no long side, take its x
    long_axis = target.placement[:2, 0] if round_in_plan or extents[0] > extents[1] else target.placement[:2, 1]
    broadside = np.array([-long_axis[1], long_axis[0]]) / np.linalg.norm(long_axis)
    candidates = []
    for sign in (1.0, -1.0):
        for turn in np.deg2rad([35.0, -35.0]):
            c, s = np.cos(turn), np.sin(turn)
            candidates.append(sign * np.array([c * broadside[0] - s * broadside[1], s * broadside[0] + c * broadside[1]]))
    towards = towards / np.linalg.norm(towards) if np.linalg.norm(towards) > 1e-6 else np.array([0.0, -1.0])
    return sorted(candidates, key=lambda d: -nearly(float(d @ towards)))


def _tour(poses: list[np.ndarray], start_xy: np.ndarray) -> list[np.ndarray]:
    remaining, ordered, here = list(poses), [], start_xy
    while remaining:
        nearest = min(range(len(remaining)), key=lambda k: np.linalg.norm(remaining[k][:2, 3] - here))
        ordered.append(remaining.pop(nearest))
        here = ordered[-1][:2, 3]
    return ordered
