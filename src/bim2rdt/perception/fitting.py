"""Registering one found object with SG-ICP: where it starts, whether it rests on the slab, which fit is kept.

Starts: the BIM pose as it is (most objects have not moved), the BIM pose slid in the plane so its box centre
stands on the points' (a moved object), and the detector's own pose when it has one (the geometric detector
registered the cluster to name it). Each start gets the family's upright prior and, unless the detector already
searched yaw, the usual yaw restarts. When the BIM pose explains the points within ``tie_ratio`` of the best
score it wins the tie: the BIM is the prior.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from bim2rdt.registration import IcpConfig, RegistrationResult, register
from bim2rdt.semantics import DEFAULT_UPRIGHT_BIAS, UprightPrior

UP = np.array([0.0, 0.0, 1.0])


def slid(T: np.ndarray, model_pts: np.ndarray, points_world: np.ndarray) -> np.ndarray:
    """``T`` moved in the plane so the posed model's box centre (5-95 % extent along its body x and y) lies on
    the points': extents are not pulled to the near side, where perspective puts most corners."""
    axes = T[:2, :2]
    model_world = model_pts @ T[:3, :3].T + T[:3, 3]
    out = T.copy()
    out[:2, 3] += axes @ (_box_centre(points_world, axes) - _box_centre(model_world, axes))
    return out


def along_long_axis(T: np.ndarray, model_pts: np.ndarray, points_world: np.ndarray,
                    slender: float = 3.0) -> list[np.ndarray]:
    """``T`` itself and, for a slender object (a beam, a pipe: plan length over ``slender`` x its width), ``T``
    shifted either way along its long axis so the seen part sits at one end: a partial view of a beam pins
    where it lies across its length, not along it, and the rest of it may be behind whatever hides it."""
    extents = np.ptp(model_pts[:, :2], axis=0)
    if extents.max() < slender * max(extents.min(), 1e-6):
        return [T]
    axis = T[:3, int(np.argmax(extents))]
    seen = np.ptp(points_world @ axis) if len(points_world) else 0.0
    shift = max(0.0, (extents.max() - seen) / 2)
    return [T] + [_shifted(T, sign * shift * axis) for sign in (1.0, -1.0) if shift > 0.05]


def _shifted(T: np.ndarray, offset: np.ndarray) -> np.ndarray:
    out = T.copy()
    out[:3, 3] += offset
    return out


def _box_centre(points_world: np.ndarray, axes: np.ndarray) -> np.ndarray:
    low, high = np.percentile(points_world[:, :2] @ axes, [5.0, 95.0], axis=0)
    return (low + high) / 2


def upright_on(points_world: np.ndarray, model_pts: np.ndarray, slab_height: float) -> np.ndarray:
    """An upright start at zero yaw with the model's plan centre on the points' median, resting on the slab."""
    T = np.eye(4)
    T[:2, 3] = np.median(points_world[:, :2], axis=0) - model_pts[:, :2].mean(axis=0)
    T[2, 3] = slab_height
    return T


def rests_on_slab(T: np.ndarray, model_pts: np.ndarray, slab_height: float, contact: float) -> bool:
    """Whether a model posed at ``T`` has its lowest point within ``contact`` m of the slab."""
    lowest = float(np.min(model_pts @ T[:3, :3].T[:, 2] + T[2, 3]))
    return abs(lowest - slab_height) <= contact


def best_fit(model_pts: np.ndarray, model_normals: np.ndarray, points_world: np.ndarray, bim_pose: np.ndarray | None,
             other_starts: list[np.ndarray], prior: UprightPrior | None, icp: IcpConfig, support_height: float | None,
             searched: bool, tie_ratio: float,
             plausible: Callable[[RegistrationResult], bool] = lambda fit: True) -> RegistrationResult:
    """The kept registration over all starts (see the module docs). ``searched``: the detector's pose already
    came from a search (``other_starts``), so the BIM pose and it are refined locally (one restart each) and no
    slid guesses are needed.
    ``plausible`` rules fits out (a model whose far side faces the camera); if it rules out all, all count."""
    bias = prior.upright_bias if prior else DEFAULT_UPRIGHT_BIAS
    yaw_only = prior.yaw_only if prior else False
    local = icp.model_copy(update={"restarts": 1, "yaw_jitter_deg": 0.0})

    def fit_from(T: np.ndarray, cfg: IcpConfig) -> RegistrationResult:
        return register(model_pts, model_normals, points_world, init=T, up=UP, upright_bias=bias, yaw_only=yaw_only,
                        config=cfg, support_height=support_height)

    guesses = [] if bim_pose is None else [bim_pose] if searched else \
        [bim_pose, *along_long_axis(slid(bim_pose, model_pts, points_world), model_pts, points_world)]
    starts = guesses + other_starts
    fits = [fit_from(T, local if searched else icp) for T in starts]
    kept = [f for f in fits if plausible(f)] or fits
    best = min(kept, key=lambda f: f.score)
    if bim_pose is None:
        return best
    at_bim = fits[0] if searched else fit_from(bim_pose, local)
    return at_bim if at_bim.score <= tie_ratio * best.score and plausible(at_bim) else best
