"""Registering one detected object: where SG-ICP starts, whether the object rests on the slab, and which fit is
kept (the BIM pose wins a near-tie)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from bim2rdt.mission.config import MissionConfig
from bim2rdt.mission.ground import UP_WORLD, box_centre
from bim2rdt.mission.records import Target
from bim2rdt.perception.detection import Detection
from bim2rdt.registration import IcpConfig, RegistrationResult, register
from bim2rdt.semantics import UprightPrior


def initial_poses(detection: Detection, target: Target | None, model_pts: np.ndarray,
                  config: MissionConfig) -> list[np.ndarray]:
    """Where to start: the BIM pose as it is (most objects have not moved), and the BIM pose slid in the plane
    so the model's box centre stands on the detection's (for moved ones); a new object starts upright at zero
    yaw on the detection; then the detector's own pose (``Detection.pose``), when it gives one. The
    registration's yaw restarts cover the rest."""
    T = target.placement.copy() if target else np.eye(4)
    axes = T[:2, :2]  # the object's body x and y, in the world plane
    model_world = model_pts @ T[:3, :3].T + T[:3, 3]
    slid = T.copy()
    slid[:2, 3] += axes @ (box_centre(detection.points_world, axes, config)
                           - box_centre(model_world, axes, config))
    starts = [T, slid] if target else [slid]
    detector = [detection.pose] if detection.pose is not None else []  # the detector's own guess, if it has one
    return starts + detector + _along_long_axis(slid, model_pts)


def _along_long_axis(T: np.ndarray, model_pts: np.ndarray, slender: float = 3.0) -> list[np.ndarray]:
    """For a slender object (a beam, a pipe) also start a quarter length either way along its long axis:
    its sides are parallel to that axis, so only the ends pin where along it the object lies."""
    extents = np.ptp(model_pts[:, :2], axis=0)
    if extents.max() < slender * max(extents.min(), 1e-6):
        return []
    axis = T[:3, int(np.argmax(extents))] * 0.25 * extents.max()
    return [_shifted(T, axis), _shifted(T, -axis)]


def _shifted(T: np.ndarray, offset: np.ndarray) -> np.ndarray:
    out = T.copy()
    out[:3, 3] += offset
    return out


def rests_on_slab(target: Target | None, model_pts: np.ndarray, config: MissionConfig) -> bool:
    """Whether the object stands on the slab: the BIM places its lowest point within ``slab_contact`` of it (a
    beam on trestles does not), and a new object found by the robot is taken to stand on it."""
    if target is None:
        return True
    lowest = float(np.min(model_pts @ target.placement[:3, :3].T[:, 2] + target.placement[2, 3]))
    return abs(lowest - config.slab_height) <= config.slab_contact


def best_fit(model_pts: np.ndarray, model_normals: np.ndarray, object_pts: np.ndarray, inits: list[np.ndarray],
             prior: UprightPrior, config: MissionConfig, icp: IcpConfig, local_first: bool,
             support_height: float | None = None,
             plausible: Callable[[RegistrationResult], bool] = lambda fit: True) -> RegistrationResult:
    """Register from every start (yaw restarts each) and keep the lowest score among the ``plausible`` fits (all
    of them when none is). With ``local_first`` the first start (the BIM pose) is also refined without
    restarts, and that local fit wins any near-tie if plausible: when two yaws explain the points equally well
    (a tripod's three legs), the BIM's is the likelier. ``plausible`` is the free-space test: a drum fitted to
    a small arc of its near side with its body on the camera's side of the arc (the mirror solution, as good by
    ICP's distances) stands where the camera saw through."""
    def fit_from(init: np.ndarray, cfg: IcpConfig) -> RegistrationResult:
        return register(model_pts, model_normals, object_pts, init=init, up=UP_WORLD,
                        upright_bias=prior.upright_bias, yaw_only=prior.yaw_only, config=cfg,
                        support_height=support_height)

    fits = [fit_from(init, icp) for init in inits]
    best = min([f for f in fits if plausible(f)] or fits, key=lambda f: f.score)
    if not local_first:
        return best
    local = fit_from(inits[0], icp.model_copy(update={"restarts": 1, "yaw_jitter_deg": 0.0}))
    return local if local.score <= config.tie_ratio * best.score and plausible(local) else best
