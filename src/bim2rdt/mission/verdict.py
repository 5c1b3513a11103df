"""The verdict on a registered object against its BIM placement: as planned, deviating (moved or turned), new
or unverified (:class:`~bim2rdt.twin.ElementStatus`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bim2rdt.mission.config import MissionConfig
from bim2rdt.mission.records import Target
from bim2rdt.registration import RegistrationResult
from bim2rdt.registration.symmetry import closest_equivalent
from bim2rdt.twin.status import ElementStatus


def pose_delta(T_ref: np.ndarray, T: np.ndarray) -> tuple[float, float, float]:
    """Horizontal shift (m), yaw change (deg, wrapped to +-180) and tilt of T's up axis from world z (deg)."""
    shift = float(np.linalg.norm(T[:2, 3] - T_ref[:2, 3]))
    yaw = np.rad2deg(np.arctan2(T[1, 0], T[0, 0]) - np.arctan2(T_ref[1, 0], T_ref[0, 0]))
    tilt = float(np.rad2deg(np.arccos(np.clip(T[2, 2], -1.0, 1.0))))
    return shift, float((yaw + 180.0) % 360.0 - 180.0), tilt


@dataclass(frozen=True)
class Verdict:
    """The status of one registered object and the deltas behind it, against its BIM placement modulo the
    family's symmetry: ``shift`` (m, horizontal), ``yaw_deg`` (wrapped to +-180), ``tilt_deg`` (from world z)."""

    status: ElementStatus
    shift: float
    yaw_deg: float
    tilt_deg: float


def judge(target: Target | None, fit: RegistrationResult, symmetry: float, config: MissionConfig) -> Verdict:
    """The verdict on ``fit`` against ``target``'s placement (its own pose for a new object). The fit is first
    turned by the symmetry (the prior's rotational order about up) that brings it closest to the BIM, so a drum
    turned about its own axis, or a pallet turned end for end, has not deviated."""
    reference = target.placement if target else fit.pose
    shift, yaw, tilt = pose_delta(reference, closest_equivalent(fit.pose, reference, symmetry))
    return Verdict(verdict(target, fit, shift, yaw, tilt, config), shift, yaw, tilt)


def verdict(target: Target | None, fit: RegistrationResult, shift: float, yaw: float, tilt: float,
            config: MissionConfig) -> ElementStatus:
    """UNVERIFIED when the fit explains too few points to trust, NEW for an object the BIM lacks, DEVIATING when
    moved or turned beyond the tolerances (``moved_translation`` m, ``moved_rotation_deg``), else AS_PLANNED."""
    if fit.fitness < config.min_fitness:
        return ElementStatus.UNVERIFIED
    if target is None:
        return ElementStatus.NEW
    deviated = (shift > config.moved_translation or abs(yaw) > config.moved_rotation_deg
                or tilt > config.moved_rotation_deg)
    return ElementStatus.DEVIATING if deviated else ElementStatus.AS_PLANNED
