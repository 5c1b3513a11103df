"""The verdict on a registered object against its BIM placement: as planned, moved, new or unverified."""

from __future__ import annotations

import numpy as np

from bim2rdt.mission.config import MissionConfig
from bim2rdt.mission.records import Target
from bim2rdt.registration import RegistrationResult


def pose_delta(T_ref: np.ndarray, T: np.ndarray) -> tuple[float, float, float]:
    """Horizontal shift (m), yaw change (deg, wrapped to +-180) and tilt of T's up axis from world z (deg)."""
    shift = float(np.linalg.norm(T[:2, 3] - T_ref[:2, 3]))
    yaw = np.rad2deg(np.arctan2(T[1, 0], T[0, 0]) - np.arctan2(T_ref[1, 0], T_ref[0, 0]))
    tilt = float(np.rad2deg(np.arccos(np.clip(T[2, 2], -1.0, 1.0))))
    return shift, float((yaw + 180.0) % 360.0 - 180.0), tilt


def verdict(target: Target | None, fit: RegistrationResult, shift: float, yaw: float, tilt: float,
            config: MissionConfig) -> str:
    if fit.fitness < config.min_fitness:
        return "unverified"
    if target is None:
        return "new"
    deviated = (shift > config.moved_translation or abs(yaw) > config.moved_rotation_deg
                or tilt > config.moved_rotation_deg)
    return "moved" if deviated else "as-planned"
