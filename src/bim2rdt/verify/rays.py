"""What the sensor measured along a direction: a lookup of its returns by direction, for free-space tests (the
sensor saw past a point: nothing solid stands there)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bim2rdt.registration import SampleTree


@dataclass(frozen=True)
class RangeLookup:
    """The sensor's returns as (unit direction, range) in the world frame, from ``origin`` (3,)."""

    origin: np.ndarray
    tree: SampleTree
    ranges: np.ndarray
    max_angle: float

    @classmethod
    def of(cls, points_sensor: np.ndarray, T_world_sensor: np.ndarray, max_angle_deg: float = 0.5) -> RangeLookup:
        """The lookup of ``points_sensor`` (N, 3, finite) seen from ``T_world_sensor``; a direction farther than
        ``max_angle_deg`` from every return has no measurement."""
        ranges = np.linalg.norm(points_sensor, axis=1)
        directions = (points_sensor / ranges[:, None]) @ T_world_sensor[:3, :3].T
        return cls(T_world_sensor[:3, 3].copy(), SampleTree(directions), ranges, np.deg2rad(max_angle_deg))

    def compare(self, points_world: np.ndarray, margin: float) -> np.ndarray:
        """(K,) per point: 1 the sensor measured past it by more than ``margin`` (seen through), -1 nearer by
        more than ``margin`` (hidden behind something), 0 on it, NaN no return on its ray."""
        offset = points_world - self.origin
        distance = np.linalg.norm(offset, axis=1)
        gap, index = self.tree.query(offset / distance[:, None], distance_upper_bound=self.max_angle)
        found = np.isfinite(gap)
        out = np.full(len(points_world), np.nan)
        measured = self.ranges[index[found]]
        out[found] = np.where(measured > distance[found] + margin, 1.0,
                              np.where(measured < distance[found] - margin, -1.0, 0.0))
        return out

    def seen_through(self, points_world: np.ndarray, margin: float) -> np.ndarray:
        """(K,) bool: points the sensor measured past by more than ``margin`` m on (nearly) their own ray."""
        offset = points_world - self.origin
        distance = np.linalg.norm(offset, axis=1)
        gap, index = self.tree.query(offset / distance[:, None], distance_upper_bound=self.max_angle)
        found = np.isfinite(gap)
        out = np.zeros(len(points_world), dtype=bool)
        out[found] = self.ranges[index[found]] > distance[found] + margin
        return out
