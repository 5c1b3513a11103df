"""The one 4-DoF fix both localizers share: a camera frame (:func:`~bim2rdt.localization.localize`) and a point
cloud (:func:`~bim2rdt.localization.localize_cloud`) differ only in how the BIM's visible surface is sampled and
how their points are made, which a :class:`SensorView` says; the fix itself is here, once:

1. the BIM's permanent surface visible from the prior (``view.visible``: coarse), and the points placed by the
   prior within the basin (``max_correction``) of it;
2. yaw-only registration of those points to it (the IMU fixes roll and pitch, the view fixes yaw and position),
   then a polish from the coarse fix against the surface visible from there; a fix that moved or turned beyond
   the basin is refused;
3. the judgement at the final pose: enough points on the BIM, few behind walls, and the covariance and free
   directions from the agreeing pairs (``observability``).

Every refusal is a :class:`~bim2rdt.localization.LocalizationError` whose ``kind`` says why.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from scipy.spatial import cKDTree

from bim2rdt.frames import rigid_problem
from bim2rdt.localization.config import LocalizationConfig
from bim2rdt.localization.errors import LocalizationError, Refusal
from bim2rdt.localization.observability import Observability, lever_arm, observability, pair_information
from bim2rdt.localization.surfaces import PermanentMap, SurfaceSamples
from bim2rdt.registration import IcpConfig, RegistrationError, invert_poses, register, unit_up


@dataclass(frozen=True)
class Localization:
    """A BIM fix of one frame. ``pose`` T_world_camera (4, 4); ``covariance`` (6, 6) of the camera's world-frame
    error (dx, dy, dz, dtheta_x, dtheta_y, dtheta_z: m, rad; the tilt terms are the IMU's); ``inliers`` depth
    points within ``inlier_distance`` of a permanent surface; ``degenerate`` unit world directions the view
    cannot fix (the covariance is ``unconstrained_sigma`` squared along them); ``residual`` RMS distance of the
    inliers to the surfaces, m. Also: ``degenerate_yaw`` (the view cannot fix the heading either),
    ``information`` (6, 6, zero along free directions; what a filter should fuse), ``points`` (depth points
    used), ``near`` (those within the basin of the map), ``moved`` (m) and ``turned_deg`` (the fix's correction
    of the prior), ``prior`` (4, 4)."""

    pose: np.ndarray
    covariance: np.ndarray
    inliers: int
    degenerate: list[np.ndarray]
    residual: float
    degenerate_yaw: bool
    information: np.ndarray
    points: int
    near: int
    moved: float
    turned_deg: float
    prior: np.ndarray


class SensorView(Protocol):
    """What the fix needs of a sensor: its points and normals in the sensor frame (metres; normals unit, NaN
    where none), how to sample the BIM it could see from a pose, and how many of its points a pose puts behind
    walls. ``sensor`` ("camera", "sensor") and ``returns`` ("depth points", "thinned points") name them in
    messages; ``needs_normals``: a fix whose inliers have no normal that agrees is refused (a camera's normals
    come from its grid, so none means broken-up returns) rather than judged on all inliers (a scan's)."""

    sensor: str
    returns: str
    needs_normals: bool
    points: np.ndarray
    normals: np.ndarray

    def visible(self, T_world_sensor: np.ndarray, coarse: bool) -> SurfaceSamples: ...

    def behind(self, T_world_sensor: np.ndarray, tolerance: float) -> float: ...


def fix_pose(view: SensorView, prior: np.ndarray, up_world: np.ndarray, cfg: LocalizationConfig) -> Localization:
    """The 4-DoF fix of ``view`` from ``prior`` (see the module's note).

    Args:
        view: The sensor's points and its way of seeing the BIM.
        prior: 4x4 T_world_sensor prior, metres (rigid; :func:`rigid_prior`).
        up_world: The world up in the world frame as the IMU measured it, unit (:func:`checked_up`).
        cfg: Localization's settings.

    Returns:
        The fix, with its covariance, information and free directions.

    Raises:
        LocalizationError: No permanent element near the points, a failed registration, a fix beyond the basin,
            too few inliers, too many points behind walls, or no usable normal; ``kind`` says which.
    """
    pose, near = _fit(view, prior, _coarse_icp(cfg), up_world, cfg, coarse=True)
    if cfg.polish_iterations > 0:
        pose, _ = _fit(view, pose, _polish_icp(cfg), up_world, cfg, coarse=False)
    moved, turned = _correction(prior, pose, up_world)
    if moved > cfg.max_correction or turned > cfg.max_correction_deg:
        raise LocalizationError(f"the fix moved the {view.sensor} {moved:.2f} m and turned it {turned:.1f} deg from "
                                f"the prior, beyond the basin ({cfg.max_correction} m, {cfg.max_correction_deg} deg): "
                                "rejected", Refusal.BEYOND_BASIN)
    return _judge(view, view.visible(pose, False), pose, prior, up_world, near, (moved, turned), cfg)


def _fit(view: SensorView, start: np.ndarray, icp: IcpConfig, up_world: np.ndarray, cfg: LocalizationConfig,
         coarse: bool) -> tuple[np.ndarray, int]:
    """One registration pass: the surface visible from ``start``, the points placed by ``start``, yaw-only ICP.
    The BIM samples are the registration's 'model' in world coordinates (body = world) and the placed points its
    'scene'; the registration's pose T maps the BIM onto the points, so the sensor is T^-1 @ start.
    Returns (T_world_sensor, number of points within the basin)."""
    visible = view.visible(start, coarse)
    placed = view.points @ start[:3, :3].T + start[:3, 3]
    near = _within(placed, visible, cfg.max_correction)
    if len(visible.points) < 6 or near.sum() < cfg.min_points:
        noun = "frame" if view.sensor == "camera" else "cloud"
        raise LocalizationError(f"the {noun} sees no permanent element: {int(near.sum())} of its {len(placed)} "
                                f"{view.returns} lie within {cfg.max_correction} m of a wall, column, slab, stair or "
                                f"door seen from the prior, need {cfg.min_points}", Refusal.NO_PERMANENT_IN_VIEW)
    centre = np.eye(4)
    centre[:3, 3] = start[:3, 3]  # the BIM's body frame sits at the sensor: yaw turns about it, not far away
    try:
        fit = register(visible.points - centre[:3, 3], visible.normals, placed[near], init=centre, up=up_world,
                       upright_bias=0.0, yaw_only=True, config=icp, report=False)  # only the pose is read
    except RegistrationError as error:
        raise LocalizationError(f"registration failed: {error}", Refusal.REGISTRATION) from None
    return centre @ invert_poses(fit.pose) @ start, int(near.sum())


def _judge(view: SensorView, visible: SurfaceSamples, pose: np.ndarray, prior: np.ndarray, up_world: np.ndarray,
           near: int, correction: tuple[float, float], cfg: LocalizationConfig) -> Localization:
    """Inliers, residual and observability at the final pose; a fix that explains too few points or puts them
    behind walls is refused."""
    moved = f"the fix moved the {view.sensor} {correction[0]:.2f} m and turned it {correction[1]:.1f} deg from the prior"
    placed = view.points @ pose[:3, :3].T + pose[:3, 3]
    inlier, along, model_normals, agree = _pairs(placed, view.normals @ pose[:3, :3].T, visible, cfg)
    count = int(inlier.sum())
    if count < cfg.min_inliers or count < cfg.min_inlier_fraction * near:
        raise LocalizationError(f"{moved}, but only {count} of the {near} {view.returns} near the map lie on it "
                                f"(need {cfg.min_inliers} and {cfg.min_inlier_fraction:.0%}): the prior is probably "
                                "beyond the basin, or the depth is warped; rejected", Refusal.FEW_INLIERS)
    behind = view.behind(pose, cfg.behind_tolerance)
    if behind > cfg.max_behind_fraction:
        raise LocalizationError(f"{moved}, but from there {behind:.0%} of the {view.returns} would lie behind walls, "
                                f"columns or slabs (at most {cfg.max_behind_fraction:.0%}): the prior is probably "
                                "beyond the basin; rejected", Refusal.BEHIND_WALLS)
    residual = float(np.sqrt(np.mean(along[inlier] ** 2)))
    used = inlier & agree
    if view.needs_normals and not used.any():
        raise LocalizationError(f"{moved}, but none of its {count} inliers has a surface normal (each needs finite "
                                "depth at its grid neighbours; this frame's returns are too broken up), so nothing "
                                "says what the view constrains: rejected", Refusal.NO_NORMALS)
    if not view.needs_normals and used.sum() < 6:
        used = inlier
    seen = _observability(placed[used], model_normals[used], pose[:3, 3], up_world, residual, cfg)
    return Localization(pose=pose, covariance=seen.covariance, inliers=count, degenerate=seen.degenerate_translations,
                        residual=residual, degenerate_yaw=bool(seen.degenerate_rotations), information=seen.information,
                        points=len(placed), near=near, moved=correction[0], turned_deg=correction[1], prior=prior)


def _within(points: np.ndarray, visible: SurfaceSamples, distance: float) -> np.ndarray:
    if len(visible.points) == 0:
        return np.zeros(len(points), bool)
    gap, _ = sample_tree(visible.points).query(points, distance_upper_bound=distance)
    return np.isfinite(gap)


def sample_tree(points: np.ndarray) -> cKDTree:
    """A k-d tree over ray-cast surface samples, built for bounded nearest-sample queries. The samples lie on
    planes (many share a coordinate exactly), and scipy's defaults (16-point leaves, boxes shrunk to their
    points) make a query from a depth point far off every surface (a person, an object, a view through a door)
    visit many leaves: the basin test of a cluttered view took 0.11 s. Larger leaves with unshrunk boxes answer
    the same queries exactly in a quarter of that (scipy's query is exact whatever the tree's shape).

    Args:
        points: (M, 3) surface samples, metres.

    Returns:
        The tree.
    """
    return cKDTree(points, leafsize=64, balanced_tree=False, compact_nodes=False)


def _coarse_icp(cfg: LocalizationConfig) -> IcpConfig:
    """The engine's settings for a fix from the prior: one start (the prior's yaw is within degrees, so no yaw
    restarts), pairs up to the basin, the Huber scale annealed from there to the depth noise."""
    return IcpConfig(restarts=1, yaw_jitter_deg=0.0, max_iterations=cfg.max_iterations,
                     max_pair_distance=cfg.max_correction, huber_delta=cfg.huber_delta,
                     normal_gate_deg=cfg.normal_gate_deg, score_distance=cfg.inlier_distance, release_iterations=0)


def _polish_icp(cfg: LocalizationConfig) -> IcpConfig:
    """A short pass from the coarse fix against the surface visible from it: tight pairs, little annealing."""
    return _coarse_icp(cfg).model_copy(update={"max_iterations": cfg.polish_iterations, "huber_anneal_iterations": 2,
                                               "max_pair_distance": max(4 * cfg.huber_delta, cfg.inlier_distance)})


def _pairs(placed: np.ndarray, normals_world: np.ndarray, visible: SurfaceSamples, cfg: LocalizationConfig):
    """Each placed point's nearest visible BIM sample: (inlier: within ``inlier_distance`` of its surface, distance
    to the surface, the surface's normal, agree: the point's own normal (NaN at depth edges) faces the same way
    within ``normal_gate_deg``). Only agreeing inliers inform the covariance: a point on a wall face just past a
    door's edge lies on the plane of the reveal next to it, and pairing it there would claim a constraint that
    is not in the view."""
    distance, index = sample_tree(visible.points).query(placed, distance_upper_bound=cfg.inlier_distance * 3)
    found = np.isfinite(distance)
    index = np.where(found, index, 0)
    model_normals = visible.normals[index]
    along = np.where(found, np.abs(np.einsum("ni,ni->n", model_normals, placed - visible.points[index])), np.inf)
    cos = np.abs(np.einsum("ni,ni->n", np.nan_to_num(normals_world), model_normals))
    agree = np.all(np.isfinite(normals_world), axis=1) & (cos >= np.cos(np.deg2rad(cfg.normal_gate_deg)))
    return along < cfg.inlier_distance, along, model_normals, agree


def behind_fraction(points_sensor: np.ndarray, pose: np.ndarray, surfaces: PermanentMap, tolerance: float) -> float:
    """Fraction of the points farther than ``tolerance`` m beyond the first permanent surface on their ray from
    ``pose``'s position: a sensor cannot see through walls, so from the right pose almost none do (openings the
    BIM lacks and walls not built yet aside), and from a wrong one many do.

    Args:
        points_sensor: (N, 3) points in the sensor frame, metres.
        pose: 4x4 T_world_sensor.
        surfaces: The permanent map.
        tolerance: Metres past the surface a point may lie (depth noise).

    Returns:
        The fraction in [0, 1].
    """
    distance = np.linalg.norm(points_sensor, axis=1)
    first = surfaces.first_hit(pose[:3, 3], (points_sensor / distance[:, None]) @ pose[:3, :3].T)
    return float(np.sum(distance > first + tolerance)) / max(len(points_sensor), 1)


def _observability(points: np.ndarray, normals: np.ndarray, centre: np.ndarray, up_world: np.ndarray,
                   residual: float, cfg: LocalizationConfig) -> Observability:
    """Information of the inlier pairs over x, y, z and the turn about up, as if the view were worth
    ``independent_points`` measurements of sigma^2 = residual^2 + surface_sigma^2; the IMU's tilt variance is
    added for roll and pitch."""
    sigma2 = residual**2 + cfg.surface_sigma**2
    information = pair_information(points, normals, centre) * (min(len(points), cfg.independent_points)
                                                                 / len(points) / sigma2)
    basis = np.zeros((6, 4))
    basis[:3, :3], basis[3:, 3] = np.eye(3), up_world
    seen = observability(information, lever_arm(points, centre), cfg.degenerate_sigma, basis,
                         cfg.unconstrained_sigma)
    tilt = np.deg2rad(cfg.imu_tilt_sigma_deg) ** 2 * (np.eye(3) - np.outer(up_world, up_world))
    seen.covariance[3:, 3:] += tilt
    return seen


def _correction(prior: np.ndarray, pose: np.ndarray, up_world: np.ndarray) -> tuple[float, float]:
    """How far the fix moved the sensor (m) and turned it about up (deg) from the prior."""
    R = pose[:3, :3] @ prior[:3, :3].T
    sin = 0.5 * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) @ up_world
    cos = 0.5 * (np.trace(R) - up_world @ R @ up_world)
    return float(np.linalg.norm(pose[:3, 3] - prior[:3, 3])), float(abs(np.rad2deg(np.arctan2(sin, cos))))


def rigid_prior(T) -> np.ndarray:
    """``T`` as a float 4x4 rigid pose, or :class:`LocalizationError` (kind ``bad input``).

    Args:
        T: The prior T_world_sensor (4x4).

    Returns:
        It, as float64.
    """
    problem = rigid_problem(T)
    if problem is not None:
        raise LocalizationError(f"prior_T_world_camera is not rigid: {problem}", Refusal.BAD_INPUT)
    return np.asarray(T, dtype=np.float64)


def checked_up(up) -> np.ndarray:
    """The registration's check of ``up`` (a unit 3-vector), raised as a :class:`LocalizationError`.

    Args:
        up: The world up as the IMU measured it.

    Returns:
        It, normalised.
    """
    try:
        return unit_up(up)
    except RegistrationError as error:
        raise LocalizationError(str(error)) from None
