"""The slab under the site objects: the BIM knows it, so its points are clutter we can name, and a body at rest
stands on it."""

from __future__ import annotations

import numpy as np

from bim2rdt.mission.config import MissionConfig
from bim2rdt.perception.slab import off_the_slab

UP_WORLD = np.array([0.0, 0.0, 1.0])


def off_slab(points_world: np.ndarray, config: MissionConfig, least: int | None = None) -> np.ndarray:
    """The ROI's points above the slab (the slab is in the BIM, so its corners are known clutter), or all of
    them when fewer than ``least`` (default ``config.min_points``) are above it."""
    return off_the_slab(points_world, slab_height=config.slab_height, clearance=config.ground_clearance,
                        least=config.min_points if least is None else least)


def object_centroid(points_world: np.ndarray, config: MissionConfig) -> np.ndarray:
    """Median (3,) of the points above the slab: robust to the ROI's clutter, for association."""
    return np.median(off_slab(points_world, config, least=1), axis=0)


def box_centre(points_world: np.ndarray, axes: np.ndarray, config: MissionConfig) -> np.ndarray:
    """Centre (2,) of the points' 5-95 % extent along the body axes ``axes`` (columns). Extents, unlike a mean
    or median, are not pulled towards the near end, where perspective puts most of the corners."""
    along = off_slab(points_world, config, least=1)[:, :2] @ axes
    low, high = np.percentile(along, [5.0, 95.0], axis=0)
    return (low + high) / 2
