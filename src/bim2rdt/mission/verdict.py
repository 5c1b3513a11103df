"""The verdict on a registered object against its BIM placement: as planned, deviating (moved or turned), new
or unverified (:class:`~bim2rdt.twin.ElementStatus`).

The mission measures the deviation the way the twin does and leaves as planned vs deviating to the twin's
tolerance presets (``Settings.twin``: temporary site objects 5 cm / 5 degrees, columns and walls 1 cm / 0.5
degrees), so the report, the twin's state and its BCF issues never disagree."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bim2rdt.mission.config import MissionConfig
from bim2rdt.mission.records import Target
from bim2rdt.registration import RegistrationResult
from bim2rdt.twin.config import TwinConfig
from bim2rdt.twin.deviation import Deviation, pose_deviation
from bim2rdt.twin.status import ElementStatus
from bim2rdt.twin.tolerance import Tolerance, TolerancePolicy
from bim2rdt.twin.verdict import against_tolerance


def pose_delta(T_ref: np.ndarray, T: np.ndarray) -> tuple[float, float, float]:
    """Horizontal shift (m), yaw change (deg, wrapped to +-180) and tilt of T's up axis from world z (deg)."""
    shift = float(np.linalg.norm(T[:2, 3] - T_ref[:2, 3]))
    yaw = np.rad2deg(np.arctan2(T[1, 0], T[0, 0]) - np.arctan2(T_ref[1, 0], T_ref[0, 0]))
    tilt = float(np.rad2deg(np.arccos(np.clip(T[2, 2], -1.0, 1.0))))
    return shift, float((yaw + 180.0) % 360.0 - 180.0), tilt


@dataclass(frozen=True)
class Verdict:
    """The status of one registered object and the deviation behind it, against its BIM placement modulo the
    family's symmetry, measured as the twin measures it (:func:`bim2rdt.twin.pose_deviation`): ``shift`` (m,
    between the origins), ``yaw_deg`` (about the element's up axis, within +-180/n), ``tilt_deg`` (between the
    up axes)."""

    status: ElementStatus
    shift: float
    yaw_deg: float
    tilt_deg: float


def judge(target: Target | None, fit: RegistrationResult, symmetry: float, config: MissionConfig,
          tolerance: Tolerance | None = None) -> Verdict:
    """The verdict on ``fit`` against ``target``'s placement (its own pose for a new object). The fit is first
    turned by the symmetry (the prior's rotational order about up) that brings it closest to the BIM, so a drum
    turned about its own axis, or a pallet turned end for end, has not deviated. As planned or deviating is the
    twin's call: ``tolerance`` is the element's preset (default: ``TwinConfig()``'s for its class and family)."""
    reference = target.placement if target else fit.pose
    deviation = pose_deviation(reference, fit.pose, symmetry)
    return Verdict(verdict(target, fit, deviation, config, tolerance), deviation.translation, deviation.yaw_deg,
                   deviation.tilt_deg)


def verdict(target: Target | None, fit: RegistrationResult, deviation: Deviation, config: MissionConfig,
            tolerance: Tolerance | None = None) -> ElementStatus:
    """UNVERIFIED when the fit explains too few points to trust, NEW for an object the BIM lacks, else the
    twin's judgement of ``deviation`` against the element's tolerance preset (AS_PLANNED or DEVIATING)."""
    if fit.fitness < config.min_fitness:
        return ElementStatus.UNVERIFIED
    if target is None:
        return ElementStatus.NEW
    return against_tolerance(deviation, tolerance or tolerance_of(target))


def tolerance_of(target: Target, policy: TolerancePolicy | None = None) -> Tolerance:
    """The target's tolerance preset under ``policy`` (default: ``TwinConfig()``'s), by family, else IFC class."""
    return (policy or _DEFAULT_POLICY).for_element(target.ifc_class, target.family)


_DEFAULT_POLICY = TwinConfig().tolerance_policy()
