"""Is the registration's pose covariance right? The true error of each estimate, in the covariance's own
parameters (:data:`bim2rdt.registration.uncertainty.POSE_PARAMETERS`), against its 95 % ellipsoid.

Only estimates that can be judged count: well-constrained ones (no unobservable direction: there the
covariance says 'unknown' on purpose) that found the right basin (rotation within 5 degrees and centroid within
5 cm modulo the family's symmetry; a covariance is a local statement and says nothing about a 90 degree flip,
which the failure modes count). A calibrated covariance puts ~95 % of those errors inside."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from bim2rdt.registration.symmetry import closest_equivalent
from bim2rdt.sim.truth import true_symmetry

INSIDE_95 = float(chi2.ppf(0.95, 6))
"""Squared Mahalanobis radius of the 95 % ellipsoid of a 6-D Gaussian (12.59)."""
BASIN_DEG, BASIN_M = 5.0, 0.05
"""An estimate within this rotation (deg) and centroid distance (m) of the truth found the right basin."""


@dataclass(frozen=True)
class CovarianceCheck:
    """One estimate: well-constrained by its own account, in the right basin, inside its 95 % ellipsoid."""

    well_constrained: bool
    in_basin: bool
    inside: bool


def pose_error_vector(family: str, T_est: np.ndarray, T_true: np.ndarray, model_pts: np.ndarray,
                      order: float | None = None) -> np.ndarray:
    """(6,) error in POSE_PARAMETERS: the rotation vector (rad, world axes) taking the estimate's orientation to
    the truth's (modulo the family's symmetry), then the true centroid minus the estimated one (m, world)."""
    shown = closest_equivalent(T_est, T_true, true_symmetry(family, order))
    rotation = Rotation.from_matrix(T_true[:3, :3] @ shown[:3, :3].T).as_rotvec()
    centroid = model_pts.mean(axis=0)
    shift = (T_true[:3, :3] @ centroid + T_true[:3, 3]) - (shown[:3, :3] @ centroid + shown[:3, 3])
    return np.concatenate([rotation, shift])


def check_covariance(result, family: str, T_true: np.ndarray, model_pts: np.ndarray,
                     order: float | None = None) -> CovarianceCheck:
    """Judge one :class:`bim2rdt.registration.RegistrationResult` against the truth."""
    error = pose_error_vector(family, result.pose, T_true, model_pts, order)
    in_basin = bool(np.rad2deg(np.linalg.norm(error[:3])) < BASIN_DEG and np.linalg.norm(error[3:]) < BASIN_M)
    inside = bool(error @ np.linalg.solve(result.covariance, error) < INSIDE_95)
    return CovarianceCheck(result.uncertainty.well_constrained, in_basin, inside)


def calibration(checks: list[CovarianceCheck]) -> tuple[float, int]:
    """(fraction inside the 95 % ellipsoid, count) over the well-constrained estimates in the right basin;
    (nan, 0) when there are none."""
    judged = [c.inside for c in checks if c.well_constrained and c.in_basin]
    return (float(np.mean(judged)) if judged else float("nan")), len(judged)
