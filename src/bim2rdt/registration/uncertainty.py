"""How well a registration pinned the pose down: the 6x6 covariance from the final Gauss-Newton system and the
residual variance, and the directions the view leaves unconstrained (degeneracy-aware ICP, as X-ICP does it:
eigen-directions of the information matrix below a threshold).

The two functions at the bottom know nothing about ICP: any least-squares estimate with residual Jacobians
(a camera pose from reprojection errors, say) gets its covariance and weak directions from them.

Parameters (:data:`POSE_PARAMETERS`): a small rotation vector r (rad) about the world x, y, z axes through the
model's centroid c, then the centroid's displacement t (m) along world x, y, z. The true pose is the estimate
perturbed: a model point at p (world, estimated) is truly at c + exp([r]x) (p - c) + t.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

POSE_PARAMETERS = ("rx", "ry", "rz", "tx", "ty", "tz")
"""Order of the pose covariance's rows: rotation (rad) about world x, y, z through the model's centroid, then the
centroid's displacement (m) along world x, y, z."""


@dataclass(frozen=True)
class PoseUncertainty:
    """A registration's pose uncertainty in :data:`POSE_PARAMETERS` (world axes, about the model's centroid).

    ``covariance`` (6, 6) rad^2, rad m, m^2; ``information`` its inverse where defined (the Gauss-Newton
    Hessian over the residual variance, priors included); ``sigma`` the residual standard deviation (m) it
    was scaled with; ``length`` (m) turns rotations into surface motion (the RMS distance of the matched model
    points from the centroid), so directions mixing rotation and translation compare in metres;
    ``unobservable`` (k, 6) unit directions in the scaled parameters (length x r, t) that the view leaves
    unconstrained, weakest first; ``strength`` (6,) the scaled information's eigenvalues over its largest."""

    covariance: np.ndarray
    information: np.ndarray
    sigma: float
    length: float
    unobservable: np.ndarray
    strength: np.ndarray

    @property
    def well_constrained(self) -> bool:
        """No direction below the threshold: the covariance then describes the error (a local, Gaussian
        statement; a wrong basin, a flipped yaw, is outside what it can say)."""
        return len(self.unobservable) == 0

    def translation_directions(self, least: float = 0.5) -> np.ndarray:
        """World directions along which the position is unconstrained.

        Args:
            least: The share of an unobservable direction's length that must be translation for it to count.

        Returns:
            (k,3) unit vectors in the world frame: the translation part of each unobservable direction that is
                mostly translation.
        """
        parts = self.unobservable[:, 3:]
        norms = np.linalg.norm(parts, axis=1)
        keep = norms >= least
        return parts[keep] / norms[keep, None]

    def rotation_axes(self, least: float = 0.5) -> np.ndarray:
        """World axes about which the orientation is unconstrained.

        Args:
            least: The share of an unobservable direction's length that must be rotation for it to count.

        Returns:
            (k,3) unit axes in the world frame, one per rotation-dominated unobservable direction.
        """
        parts = self.unobservable[:, :3]
        norms = np.linalg.norm(parts, axis=1)
        keep = norms >= least
        return parts[keep] / norms[keep, None]


def point_to_plane_jacobians(points_world: np.ndarray, normals_world: np.ndarray, centre_world: np.ndarray):
    """(N, 6) derivatives of point-to-plane residuals n . (q - p) with respect to :data:`POSE_PARAMETERS`, for
    model points p (N, 3) with unit normals n (N, 3) matched to scene points q, up to sign: moving the model
    by (r, t) moves p by r x (p - c) + t, which changes the residual by -((p - c) x n) . r - n . t."""
    return np.concatenate([np.cross(points_world - centre_world, normals_world), normals_world], axis=1)


def least_squares_information(jacobians: np.ndarray, weights: np.ndarray, sigma: float,
                              prior_information: np.ndarray | None = None) -> np.ndarray:
    """(P, P) information of a weighted least-squares estimate from its residual Jacobians (N, P), robust
    weights (N,) and residual standard deviation ``sigma``: J^T W J / sigma^2, plus ``prior_information``
    (P, P) already in 1/units^2 (the Gauss-Newton Hessian of the cost over the noise variance)."""
    information = (jacobians * weights[:, None]).T @ jacobians / max(sigma, 1e-12) ** 2
    return information if prior_information is None else information + prior_information


def split_information(information: np.ndarray, scales: np.ndarray, threshold: float, reference: float | None = None,
                      weak_variance: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(covariance (P, P), weak directions (k, P), strength (P,)) from an information matrix.

    The parameters are first multiplied by ``scales`` (P,) so they share a unit (a rotation times a length
    is a surface motion in m). The eigen-directions whose eigenvalue is below ``threshold`` x ``reference``
    are weak, weakest first; strength is every eigenvalue over ``reference``, ascending. This is the
    degeneracy test of degeneracy-aware ICP (Zhang et al. 2016; X-ICP, Tuna et al. 2023), made scale-free:
    ``reference`` is the information a direction would get if every measurement constrained it fully (for
    residuals of unit sensitivity: their total weight over sigma^2), so the strength reads as the share of
    the data that pins the direction down, whatever the number of points; None compares with the best
    direction instead. The covariance inverts the information along the other directions and puts
    ``weak_variance`` (scaled units^2) along the weak ones: the data say nothing there, and inverting a
    near-zero eigenvalue would spill an arbitrary huge variance into every parameter."""
    scaled = information / np.outer(scales, scales)
    values, vectors = np.linalg.eigh(scaled)
    strength = np.maximum(values, 0.0) / max(values.max() if reference is None else reference, 1e-300)
    weak = strength < threshold
    variances = np.where(weak, weak_variance, 1.0 / np.where(weak, 1.0, values))
    covariance = (vectors * variances) @ vectors.T / np.outer(scales, scales)
    return covariance, vectors[:, weak].T, strength
