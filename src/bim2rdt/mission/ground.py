"""The slab under the site objects: the BIM knows it, so its points are clutter we can name. (Whether a body rests
on it is decided in the one fitting path, :func:`bim2rdt.perception.fitting.rests_on_slab`.)"""

from __future__ import annotations

import numpy as np

from bim2rdt.mission.config import MissionConfig
from bim2rdt.perception import off_the_slab


def object_points(points_world: np.ndarray, config: MissionConfig, least: int | None = None) -> np.ndarray:
    """The object's points: the ROI's points above the mission's slab (:func:`~bim2rdt.perception.slab.off_the_slab`
    at ``config.slab_height`` and ``ground_clearance``; the slab is in the BIM, so its corners are known clutter),
    or all of them when fewer than ``least`` (default ``config.min_points``) are above it."""
    return off_the_slab(points_world, slab_height=config.slab_height, clearance=config.ground_clearance,
                        least=config.min_points if least is None else least)


def object_centroid(points_world: np.ndarray, config: MissionConfig) -> np.ndarray:
    """Median (3,) of the points above the slab: robust to the ROI's clutter, for association."""
    return np.median(object_points(points_world, config, least=1), axis=0)
