"""BIM-anchored localization of one RGB-D frame: where the camera is, from the walls, columns and slabs it sees.

1. depth pixels on a grid -> camera-frame points (``depth``);
2. the BIM's permanent surfaces ray cast from the prior pose (``surfaces``): only faces the camera could see,
   so the back of a wall is never a candidate (sparsely: the coarse pass pairs points up to the basin away);
3. the points within the basin of that surface are registered to it by the registration engine in its
   ``yaw_only`` mode: the IMU fixes roll and pitch, the view fixes yaw and position (4 degrees of freedom);
   robust weights and trimming leave site objects, people and clutter out;
4. the surface is ray cast again from the coarse fix, twice as densely, and the fit polished (the true view's
   visible surface);
5. the pairs' information gives the covariance and the directions the view cannot constrain (``observability``);
6. a fix that moved farther than the basin, or that explains too few of the points, is rejected, never trusted.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from bim2rdt.bim import BimModel
from bim2rdt.frames import rigid_problem
from bim2rdt.localization.config import LocalizationConfig
from bim2rdt.localization.depth import depth_grid, grid_normals
from bim2rdt.localization.errors import LocalizationError
from bim2rdt.localization.observability import lever_arm, observability, pair_information
from bim2rdt.localization.surfaces import PermanentMap, SurfaceSamples, permanent_map
from bim2rdt.perception.frame import Frame
from bim2rdt.registration import IcpConfig, RegistrationError, register
from bim2rdt.registration.so3 import invert_poses
from bim2rdt.registration.validation import unit_up


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


def localize(frame: Frame, model: BimModel, prior_T_world_camera: np.ndarray,
             up: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 1.0),
             config: LocalizationConfig | None = None) -> Localization:
    """Fix the camera pose of a frame on the permanent elements of the model (walls, columns, slabs, stairs,
    doors), starting from the odometry prior. Yaw-only ICP: roll and pitch of the prior are kept.
    ``frame.T_world_camera`` is ignored.

    Args:
        frame: The RGB-D frame (depth in metres, OpenCV camera axes).
        model: The BIM, loaded with geometry.
        prior_T_world_camera: 4x4 camera-to-world odometry prior, metres.
        up: The world up measured by the IMU, a unit 3-vector.
        config: Localization's settings; None uses the defaults.

    Returns:
        The fix: ``pose`` (``T_world_camera``, 4x4), its (6,6) covariance and information, the directions it
            cannot fix, and its residual (metres).

    Raises:
        LocalizationError: Too few depth returns, no permanent element in view, a correction beyond the basin,
            or a bad prior or up; the message gives the reason.
    """
    cfg = config or LocalizationConfig()
    prior, up_world = _rigid_prior(prior_T_world_camera), _unit_up(up)
    surfaces = permanent_map(model)
    grid = depth_grid(frame, cfg.pixel_stride, cfg.min_range, cfg.max_range)
    valid = np.isfinite(grid[..., 2])
    points_cam, normals_cam = grid[valid], grid_normals(grid)[valid]
    if len(points_cam) < cfg.min_points:
        raise LocalizationError(f"the frame has {len(points_cam)} depth returns in {cfg.min_range}-{cfg.max_range} m "
                                f"on its {cfg.pixel_stride}-pixel grid, need {cfg.min_points}")

    def fit(start: np.ndarray, icp: IcpConfig, coarse: bool) -> tuple[np.ndarray, int]:
        stride = cfg.coarse_model_stride if coarse else cfg.model_stride
        return _fit(points_cam, surfaces, frame, start, start, up_world, icp, cfg, stride)

    pose, near, moved, turned = _within_basin(fit, prior, up_world, cfg, "camera")
    visible = surfaces.visible(pose, frame.intrinsics, cfg.model_stride, cfg.view_margin, cfg.max_range * 1.2)
    return _judge(points_cam, normals_cam, surfaces, visible, pose, prior, up_world, near, moved, turned, cfg)


def _within_basin(fit: Callable[[np.ndarray, IcpConfig, bool], tuple[np.ndarray, int]], prior: np.ndarray,
                  up_world: np.ndarray, cfg: LocalizationConfig, sensor: str) -> tuple[np.ndarray, int, float, float]:
    """The coarse fit from the prior, polished from the coarse fix (``fit(start, icp, coarse)`` -> (pose, points
    within the basin)), kept only within the basin: (pose, near, moved m, turned deg). Raises
    :class:`LocalizationError` naming the ``sensor`` when the fix moved or turned beyond it."""
    pose, near = fit(prior, _coarse_icp(cfg), True)
    if cfg.polish_iterations > 0:
        pose, _ = fit(pose, _polish_icp(cfg), False)
    moved, turned = _correction(prior, pose, up_world)
    if moved > cfg.max_correction or turned > cfg.max_correction_deg:
        raise LocalizationError(f"the fix moved the {sensor} {moved:.2f} m and turned it {turned:.1f} deg from the "
                                f"prior, beyond the basin ({cfg.max_correction} m, {cfg.max_correction_deg} deg): "
                                "rejected")
    return pose, near, moved, turned


def _fit(points_cam: np.ndarray, surfaces: PermanentMap, frame: Frame, view: np.ndarray, start: np.ndarray,
         up_world: np.ndarray, icp: IcpConfig, cfg: LocalizationConfig, stride: int) -> tuple[np.ndarray, int]:
    """One registration pass: the surface visible from ``view`` (ray cast every ``stride``-th pixel), the points
    placed by ``start``, yaw-only ICP.
    The BIM samples are the registration's 'model' in world coordinates (body = world) and the placed points its
    'scene'; the registration's pose T maps the BIM onto the points, so the camera is T^-1 @ start.
    Returns (T_world_camera, number of points within the basin)."""
    visible = surfaces.visible(view, frame.intrinsics, stride, cfg.view_margin, cfg.max_range * 1.2)
    placed = points_cam @ start[:3, :3].T + start[:3, 3]
    near = _within(placed, visible, cfg.max_correction)
    if len(visible.points) < 6 or near.sum() < cfg.min_points:
        raise LocalizationError(f"the frame sees no permanent element: {int(near.sum())} of its {len(placed)} depth "
                                f"points lie within {cfg.max_correction} m of a wall, column, slab, stair or door "
                                f"seen from the prior, need {cfg.min_points}")
    centre = np.eye(4)
    centre[:3, 3] = start[:3, 3]  # the BIM's body frame sits at the camera: yaw turns about it, not far away
    try:
        fit = register(visible.points - centre[:3, 3], visible.normals, placed[near], init=centre, up=up_world,
                       upright_bias=0.0, yaw_only=True, config=icp)
    except RegistrationError as error:
        raise LocalizationError(f"registration failed: {error}") from None
    return centre @ invert_poses(fit.pose) @ start, int(near.sum())


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
    the same queries exactly in a quarter of that (scipy's query is exact whatever the tree's shape)."""
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


def _judge(points_cam: np.ndarray, normals_cam: np.ndarray, surfaces: PermanentMap, visible: SurfaceSamples,
           pose: np.ndarray, prior: np.ndarray, up_world: np.ndarray, near: int, moved: float, turned: float,
           cfg: LocalizationConfig) -> Localization:
    """Inliers, residual and observability at the final pose; reject a fix that explains too few points or puts
    them behind walls."""
    placed = points_cam @ pose[:3, :3].T + pose[:3, 3]
    inlier, along, model_normals, agree = _pairs(placed, normals_cam @ pose[:3, :3].T, visible, cfg)
    count = int(inlier.sum())
    if count < cfg.min_inliers or count < cfg.min_inlier_fraction * near:
        raise LocalizationError(f"the fix moved the camera {moved:.2f} m and turned it {turned:.1f} deg from the "
                                f"prior, but only {count} of the {near} depth points near the map lie on it (need "
                                f"{cfg.min_inliers} and {cfg.min_inlier_fraction:.0%}): the prior is probably beyond "
                                "the basin; rejected")
    behind = behind_the_map(points_cam, pose, surfaces, cfg.behind_tolerance)
    if behind > cfg.max_behind_fraction:
        raise LocalizationError(f"the fix moved the camera {moved:.2f} m and turned it {turned:.1f} deg from the "
                                f"prior, but from there {behind:.0%} of the depth points would lie behind walls, "
                                f"columns or slabs (at most {cfg.max_behind_fraction:.0%}): the prior is probably "
                                "beyond the basin; rejected")
    residual = float(np.sqrt(np.mean(along[inlier] ** 2)))
    used = inlier & agree
    if not used.any():
        raise LocalizationError(f"the fix moved the camera {moved:.2f} m and turned it {turned:.1f} deg from the "
                                f"prior, but none of its {count} inliers has a surface normal (each needs finite "
                                "depth at its grid neighbours; this frame's returns are too broken up), so nothing "
                                "says what the view constrains: rejected")
    seen = _observability(placed[used], model_normals[used], pose[:3, 3], up_world, residual, cfg)
    return Localization(pose=pose, covariance=seen.covariance, inliers=count, degenerate=seen.degenerate_translations,
                        residual=residual, degenerate_yaw=bool(seen.degenerate_rotations), information=seen.information,
                        points=len(placed), near=near, moved=moved, turned_deg=turned, prior=prior)


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


def behind_the_map(points_cam: np.ndarray, pose: np.ndarray, surfaces: PermanentMap, tolerance: float) -> float:
    """Fraction of depth points that lie more than ``tolerance`` m beyond the first permanent surface along
    their pixel's ray from ``pose``: the camera cannot see through a wall, so from the right pose almost none
    do (openings the BIM lacks and walls not built yet aside), and from a wrong one many do."""
    depth = surfaces.first_hit(pose[:3, 3], points_cam / points_cam[:, 2:3] @ pose[:3, :3].T)  # rays with z = 1
    return float(np.sum(points_cam[:, 2] > depth + tolerance)) / max(len(points_cam), 1)


def _observability(points: np.ndarray, normals: np.ndarray, centre: np.ndarray, up_world: np.ndarray,
                   residual: float, cfg: LocalizationConfig):
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
    """How far the fix moved the camera centre (m) and turned it about up (deg) from the prior."""
    R = pose[:3, :3] @ prior[:3, :3].T
    sin = 0.5 * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) @ up_world
    cos = 0.5 * (np.trace(R) - up_world @ R @ up_world)
    return float(np.linalg.norm(pose[:3, 3] - prior[:3, 3])), float(abs(np.rad2deg(np.arctan2(sin, cos))))


def _rigid_prior(T) -> np.ndarray:
    problem = rigid_problem(T)
    if problem is not None:
        raise LocalizationError(f"prior_T_world_camera is not rigid: {problem}")
    return np.asarray(T, dtype=np.float64)


def _unit_up(up) -> np.ndarray:
    """The registration's check of ``up``, raised as a LocalizationError."""
    try:
        return unit_up(up)
    except RegistrationError as error:
        raise LocalizationError(str(error)) from None

