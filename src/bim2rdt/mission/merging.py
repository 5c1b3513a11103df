"""Merging views without the truth: one object seen from several stations must give one observation.

Objects are registered in order of their detections' point counts, so each object's best view comes first. A
later detection whose points mostly lie on the surfaces already registered (within ``merge_distance``) found
nothing new: it is another view of those objects, and it is merged into the one of its family that explains most
of its points. Only a detection whose points the registered objects do not explain becomes an object of its own.
Surfaces, not centroids: a detection's ROI also holds its neighbours' corners (a tripod in front of a drum), which
drag a centroid metres away, but those corners lie on the neighbour's registered surface."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from bim2rdt.mission.config import MissionConfig
from bim2rdt.mission.ground import object_points
from bim2rdt.mission.records import Observation
from bim2rdt.perception import Detection


@dataclass(frozen=True)
class RegisteredObject:
    """An object the mission registered: its observation and its model's surface samples at the fitted pose
    (a k-d tree over (M, 3) world points)."""

    observation: Observation
    surface_world: cKDTree

    @classmethod
    def of(cls, observation: Observation, model_pts: np.ndarray) -> RegisteredObject:
        """From the observation and its model's surface samples (M, 3, body frame)."""
        T = observation.pose
        return cls(observation, cKDTree(model_pts @ T[:3, :3].T + T[:3, 3]))

    @property
    def family(self) -> str:
        return self.observation.family

    def seen_from(self, station: int) -> None:
        """Record one more station the object was seen from (the observation's ``frames``)."""
        self.observation.frames = tuple(sorted({*self.observation.frames, station}))


def repeated_view(detection: Detection, registered: Sequence[RegisteredObject],
                  config: MissionConfig) -> RegisteredObject | None:
    """The registered object ``detection`` is another view of, or None when it shows something new.

    It is a repeated view when at least ``merge_fraction`` of its points above the slab lie within
    ``merge_distance`` of registered surfaces; its owner is the object of its family that explains most of them
    (or, when none of its family does, the object that does: a label on an object already registered)."""
    if not registered:
        return None
    points = object_points(detection.points_world, config, least=1)
    distances = np.stack([obj.surface_world.query(points, distance_upper_bound=config.merge_distance)[0]
                          for obj in registered])  # (objects, N), inf beyond the bound
    on_surface = distances <= config.merge_distance
    if on_surface.any(axis=0).mean() < config.merge_fraction:
        return None
    counts = on_surface.sum(axis=1)
    same_family = [k for k, obj in enumerate(registered) if obj.family == detection.family and counts[k] > 0]
    return registered[max(same_family or range(len(registered)), key=lambda k: counts[k])]
