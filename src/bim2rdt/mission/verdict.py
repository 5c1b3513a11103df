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
from bim2rdt.twin import (Deviation, ElementStatus, FitEvidence, Tolerance, TolerancePolicy, TwinConfig,
                          judge_evidence, pose_deviation)
from bim2rdt.twin import against_tolerance

DEFAULT_MIN_FITNESS = TwinConfig().min_fitness
"""The twin's default ``min_fitness``, for a mission run without the twin's settings."""


def pose_delta(T_ref: np.ndarray, T: np.ndarray) -> tuple[float, float, float]:
    """How far a pose is from a reference, in the floor plan.

    Args:
        T_ref: The reference pose, 4x4 model-to-world, metres.
        T: The pose, 4x4 model-to-world, metres.

    Returns:
        (horizontal shift in metres, yaw change in degrees wrapped to +-180, tilt of T's up axis from world z
            in degrees).
    """
    shift = float(np.linalg.norm(T[:2, 3] - T_ref[:2, 3]))
    yaw = np.rad2deg(np.arctan2(T[1, 0], T[0, 0]) - np.arctan2(T_ref[1, 0], T_ref[0, 0]))
    tilt = float(np.rad2deg(np.arccos(np.clip(T[2, 2], -1.0, 1.0))))
    return shift, float((yaw + 180.0) % 360.0 - 180.0), tilt


@dataclass(frozen=True)
class Verdict:
    """The status of one registered object and the deviation behind it, against its BIM placement modulo the
    family's symmetry, measured as the twin measures it (:func:`bim2rdt.twin.pose_deviation`): ``shift`` (m,
    between the origins), ``yaw_deg`` (about the element's up axis, within +-180/n), ``tilt_deg`` (between the
    up axes), and ``reason``, what follows "unverified" in a report: "along x (the view does not pin ...)" or
    "(the fit explains 40 % of its points, ...)"; empty for the other statuses."""

    status: ElementStatus
    shift: float
    yaw_deg: float
    tilt_deg: float
    reason: str = ""


def judge(target: Target | None, fit: RegistrationResult, symmetry: float, config: MissionConfig,
          tolerance: Tolerance | None = None, min_fitness: float = DEFAULT_MIN_FITNESS) -> Verdict:
    """The verdict on ``fit`` against ``target``'s placement (its own pose for a new object). The fit is first
    turned by the symmetry (the prior's rotational order about up) that brings it closest to the BIM, so a drum
    turned about its own axis, or a pallet turned end for end, has not deviated. As planned or deviating is the
    twin's call: ``tolerance`` is the element's preset (default: ``TwinConfig()``'s for its class and family), and
    so is whether the fit can be judged at all (``min_fitness``, the twin's: ``Settings.twin.min_fitness``)."""
    reference = target.placement if target else fit.pose
    deviation = pose_deviation(reference, fit.pose, symmetry)
    status, reason = verdict(target, fit, deviation, config, tolerance, symmetry, min_fitness)
    return Verdict(status, deviation.translation, deviation.yaw_deg, deviation.tilt_deg, reason)


def verdict(target: Target | None, fit: RegistrationResult, deviation: Deviation, config: MissionConfig,
            tolerance: Tolerance | None = None, symmetry: float = 1.0,
            min_fitness: float = DEFAULT_MIN_FITNESS) -> tuple[ElementStatus, str]:
    """(status, reason). UNVERIFIED when the fit explains too few points to trust (the one judge,
    :func:`bim2rdt.twin.judge_evidence`, under ``min_fitness``, as verify judges); NEW for an object the BIM
    lacks; else the twin's judgement (:func:`bim2rdt.twin.verdict.against_tolerance`, the element's tolerance
    preset) of the part of ``deviation`` the view pins down: DEVIATING when that is beyond the preset,
    UNVERIFIED when the view leaves a horizontal direction (or the yaw of a body without symmetry) unconstrained
    that could hide a deviation (the registration's unobservable directions: a box seen on one face may have
    slid along it, and an estimate along that face is the start, not evidence), else AS_PLANNED."""
    trust = judge_evidence(None, FitEvidence(fit.fitness), min_fitness)  # the one judge, shared with verify
    if trust.status is not None:
        return trust.status, trust.reason
    if target is None:
        return ElementStatus.NEW, ""
    free, free_yaw = unconstrained_motion(fit, symmetry)
    moved = fit.pose[:3, 3] - target.placement[:3, 3]
    seen = Deviation(float(np.linalg.norm(moved - free.T @ (free @ moved))), deviation.tilt_deg,
                     0.0 if free_yaw else deviation.yaw_deg)
    status = against_tolerance(seen, tolerance or tolerance_of(target))
    blind = [axis for axis in free if np.linalg.norm(axis[:2]) > 0.5]  # the slab pins the height anyway
    if status is ElementStatus.DEVIATING or not (blind or free_yaw):
        return status, ""
    parts = [f"along {axis_name(axis)}" for axis in blind] + (["in yaw"] if free_yaw else [])
    return ElementStatus.UNVERIFIED, (f"{' and '.join(parts)} (the view does not pin the pose down there, so the "
                                      "fit cannot tell whether it moved)")


def tolerance_of(target: Target, policy: TolerancePolicy | None = None) -> Tolerance:
    """The target's tolerance preset under ``policy`` (default: ``TwinConfig()``'s), by family, else IFC class."""
    return (policy or _DEFAULT_POLICY).for_element(target.ifc_class, target.family)


_DEFAULT_POLICY = TwinConfig().tolerance_policy()


def unconstrained_motion(fit: RegistrationResult, symmetry: float) -> tuple[np.ndarray, bool]:
    """(world unit vectors (k, 3) along which the fit leaves the position free, whether it leaves the yaw free),
    from the registration's unobservable directions. A free turn about the up axis counts only for a body with
    no rotational symmetry: a round body's (order ``math.inf``) is its symmetry, and a square-based cone's
    (order 4) yaw is weak by design and no site deviation anyone acts on. A fit without an uncertainty (a test
    double) is taken as fully constrained."""
    uncertainty = getattr(fit, "uncertainty", None)
    if uncertainty is None:
        return np.zeros((0, 3)), False
    axes = uncertainty.rotation_axes()
    free_yaw = bool(np.any(np.abs(axes[:, 2]) > 0.9)) and symmetry <= 1.0
    return uncertainty.translation_directions(), free_yaw


def axis_name(direction: np.ndarray) -> str:
    """'x', 'y' or 'z' for a unit vector within 25 degrees of a world axis (either sign), else its components."""
    dominant = int(np.argmax(np.abs(direction)))
    if abs(direction[dominant]) >= np.cos(np.deg2rad(25.0)):
        return "xyz"[dominant]
    return "(" + ", ".join(f"{c:.2f}" for c in direction) + ")"
