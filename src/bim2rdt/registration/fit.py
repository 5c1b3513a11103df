"""What a registration reports about its final pose: the fit on the model SURFACE (RMSE, fitness) and the pose
uncertainty from the final Gauss-Newton system (see :mod:`bim2rdt.registration.uncertainty`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bim2rdt import exact
from bim2rdt.registration import matching
from bim2rdt.registration.config import IcpConfig
from bim2rdt.registration.so3 import invert_poses
from bim2rdt.registration.uncertainty import (PoseUncertainty, least_squares_information, point_to_plane_jacobians,
                                              split_information)
from bim2rdt.registration.validation import Problem

HELD = 1e12
"""Information (1/rad^2, over sigma^2 = 1) that stands for 'held exactly': yaw_only keeps roll and pitch."""


@dataclass(frozen=True)
class FitReport:
    """RMSE (m) and fitness (0-1) over the scene points within the inlier distance of the model surface, and
    the pose uncertainty."""

    rmse: float
    fitness: float
    uncertainty: PoseUncertainty


SIGMA_FLOOR = 1e-6
"""Smallest residual spread, m: a scene that lies exactly on the model's samples (synthetic points, a model
registered to its own surface) has none, and the information is scaled by 1/sigma^2."""


def report_fit(pose: np.ndarray, problem: Problem, model: matching.ModelIndex, cfg: IcpConfig,
               upright_bias: float, yaw_only: bool = False) -> FitReport:
    """The fit of ``pose`` (T_world_model) to the scene and its uncertainty.

    Inliers are the scene points within ``cfg.score_distance`` of the model surface; each is a point-to-plane
    residual along the normal of the surface patch it lies on, Huber-weighted at ``cfg.huber_delta`` as in the
    loop's last steps. The residual variance is the inliers' (n - 6 degrees of freedom). The priors the loop
    used count as information too: the upright term (``upright_bias`` x gamma0 x the data's spread, as in the
    loop) on the tilt, the resting contact on the height, yaw_only's held roll and pitch."""
    scene_body = problem.scene_pts_world @ pose[:3, :3] - pose[:3, :3].T @ pose[:3, 3]
    patches = matching.nearest_patches(model, scene_body, cfg.score_distance)
    inliers = patches.distance < cfg.score_distance
    n = int(inliers.sum())
    rmse = float(np.sqrt(np.mean(patches.distance[inliers] ** 2))) if n else float("inf")
    if n <= 6:
        return FitReport(rmse, float(inliers.mean()), unconstrained())
    distance, sample = patches.distance[inliers], patches.sample[inliers]
    sigma = max(float(np.sqrt(np.sum(distance**2) / (n - 6))), SIGMA_FLOOR)
    weights = np.minimum(1.0, cfg.huber_delta / np.maximum(distance, 1e-12))
    on_edge = patches.other_face[inliers] - distance < 2.0 * sigma
    R = pose[:3, :3]
    centre = R @ model.centroid + pose[:3, 3]
    points, normals = problem.scene_pts_world[inliers], model.normals[sample] @ R.T
    jacobians = point_to_plane_jacobians(points, normals, centre)
    prior = _prior_information(pose, centre, problem, model.points[sample], weights, cfg, upright_bias, yaw_only)
    information = least_squares_information(jacobians, np.where(on_edge, 0.0, weights), sigma, prior / sigma**2)
    length = float(np.sqrt(np.mean(np.sum((points - centre) ** 2, axis=1))))
    covariance, directions, strength = split_information(
        information, np.array([length] * 3 + [1.0] * 3), cfg.unobservable_ratio,
        reference=float(weights.sum()) / sigma**2, weak_variance=length**2)
    floor = np.array([2.0 * cfg.convergence_rot_rad] * 3 + [2.0 * cfg.convergence_trans] * 3)
    return FitReport(rmse, float(inliers.mean()), PoseUncertainty(covariance + np.diag(floor**2), information,
                                                                  sigma, length, directions, strength))


def _prior_information(pose: np.ndarray, centre: np.ndarray, problem: Problem, matched_body: np.ndarray,
                       weights: np.ndarray, cfg: IcpConfig, upright_bias: float, yaw_only: bool) -> np.ndarray:
    """(6, 6) Gauss-Newton information of the loop's priors, in the data term's units (multiply by 1/sigma^2):
    the upright term lam |R g_m - g_w|^2 (lam = bias gamma0 sum w |p - p_mean|^2) gives lam (I - u u^T) on
    the rotation for the body's up axis u; the contact, one point-to-plane pair of weight support_weight x
    sum w; yaw_only, roll and pitch held. ``centre`` (m, world) is the model's centroid at ``pose``."""
    information = np.zeros((6, 6))
    up_body = pose[:3, 2]
    if upright_bias > 0.0:
        spread = matched_body - np.average(matched_body, axis=0, weights=weights)
        lam = upright_bias * cfg.gravity_gamma0 * float(np.sum(weights * np.sum(spread**2, axis=1)))
        information[:3, :3] += lam * (np.eye(3) - np.outer(up_body, up_body))
    if yaw_only:
        information[:3, :3] += HELD * (np.eye(3) - np.outer(problem.up_world, problem.up_world))
    if problem.support_height is not None:
        heights = problem.model_pts_body @ (pose[:3, :3].T @ problem.up_world)
        lowest = problem.model_pts_body[exact.first_smallest(heights)]  # a flat base ties: the first of it
        row = point_to_plane_jacobians((pose[:3, :3] @ lowest + pose[:3, 3])[None], problem.up_world[None],
                                       centre)[0]
        information += cfg.support_weight * float(weights.sum()) * np.outer(row, row)
    return information


def unconstrained(length: float = 1.0) -> PoseUncertainty:
    """The uncertainty of a fit with too few inliers to say anything: every direction unobservable, with the
    variance of a motion as large as ``length`` (m, and rad over it)."""
    variances = np.array([1.0 / length**2] * 3 + [length**2] * 3)
    return PoseUncertainty(np.diag(variances), np.zeros((6, 6)), float("inf"), length, np.eye(6), np.zeros(6))
