"""Registering one found object with SG-ICP: the one path from a detection to a fit, for every caller
(perception's front end, :func:`~bim2rdt.perception.perceive.perceive_frames`, and the mission's loop).

:func:`fit_detection` decides, the same way for both:

- **Whether it rests on the slab** (:func:`rests_on_slab`): the BIM pose's lowest point within ``slab_contact`` of
  the slab (a beam on trestles does not); without a BIM pose the detector's; with neither, an object the robot
  found is taken to stand on the slab. Resting, registration pulls its lowest point onto the slab.
- **Where SG-ICP starts** (:func:`start_poses`): the BIM pose as it is (most objects have not moved), the BIM pose
  slid in the plane so the model's box centre stands on the points' (a moved object; without a BIM pose, upright
  at zero yaw on the slab with its plan centre on the points' median, :func:`upright_on`), the detector's own
  poses, and for a slender object (a beam) the slid pose shifted
  along its long axis (:func:`along_long_axis`). A detector whose pose came from its own search (the geometric
  detector registers the cluster to name it) can be trusted to have searched: with
  ``FitRules.refine_detector_pose`` the BIM pose and the detector's are only refined (one restart each) and no
  slid guesses are made; otherwise every start gets the usual yaw restarts.
- **Which fit is kept**: the lowest score among the ``plausible`` fits (all of them when none is); then the BIM
  pose refined without restarts wins a near-tie (its score within ``tie_ratio`` of the best, and plausible):
  when two poses explain the points equally well (a tripod's three legs), the BIM's is the likelier.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from bim2rdt.frames import UP
from bim2rdt.registration import IcpConfig, RegistrationResult, register
from bim2rdt.semantics import DEFAULT_UPRIGHT_BIAS, UprightPrior

Plausible = Callable[[RegistrationResult], bool]
"""A fit's free-space test (a model whose far side faces the camera is not), see
:mod:`bim2rdt.perception.visibility`."""


@dataclass(frozen=True)
class FitRules:
    """The caller's settings of the one fitting path (lengths in metres): ``icp`` (the registration's),
    ``tie_ratio`` (the BIM pose wins when its score is within this factor of the best), ``slab_contact`` (a
    pose's lowest point this close to the slab rests on it) and ``refine_detector_pose`` (a detector's pose is
    the result of its own search: refine it and the BIM pose, search no further)."""

    icp: IcpConfig = field(default_factory=IcpConfig)
    tie_ratio: float = 1.15
    slab_contact: float = 0.05
    refine_detector_pose: bool = True


def fit_detection(model_pts: np.ndarray, model_normals: np.ndarray, points_world: np.ndarray,
                  bim_pose: np.ndarray | None, detector_poses: Sequence[np.ndarray], prior: UprightPrior | None,
                  slab_height: float, rules: FitRules, plausible: Plausible = lambda fit: True, *,
                  report: bool = True) -> RegistrationResult:
    """The kept registration of a model (``model_pts``/``model_normals`` (N, 3), body frame) to one object's
    ``points_world`` (M, 3), from the matched element's ``bim_pose`` (T_world_model, None for an object the BIM
    lacks) and the detector's own ``detector_poses``, under the family's upright ``prior``, on the slab at
    ``slab_height`` (m, world z). See the module docs for the rules.

    Args:
        model_pts: (N, 3) model surface samples, body frame, metres.
        model_normals: (N, 3) their unit normals.
        points_world: (M, 3) the object's points, world metres.
        bim_pose: 4x4 T_world_model of the matched element, or None.
        detector_poses: The detector's own 4x4 poses of the object.
        prior: The family's upright prior, or None.
        slab_height: World z of the slab under the object, metres.
        rules: The fitting rules (ICP, tie ratio, slab contact).
        plausible: Whether a fit may be kept (free space, ...).
        report: Report each fit (``rmse``, ``fitness``, ``uncertainty``); False for a caller that reads only the
            kept pose and score (see :func:`~bim2rdt.registration.register`): the same fit is kept either way.

    Returns:
        The kept registration.
    """
    reference = bim_pose if bim_pose is not None else (detector_poses[0] if len(detector_poses) else None)
    resting = rests_on_slab(reference, model_pts, slab_height, rules.slab_contact)
    bias = prior.upright_bias if prior else DEFAULT_UPRIGHT_BIAS
    yaw_only = prior.yaw_only if prior else False
    local = rules.icp.model_copy(update={"restarts": 1, "yaw_jitter_deg": 0.0})

    done: dict[tuple[bytes, int], RegistrationResult] = {}

    def fit_from(T: np.ndarray, cfg: IcpConfig) -> RegistrationResult:
        key = (np.asarray(T, dtype=float).tobytes(), id(cfg))  # a start given twice (verify's kept pose is both
        if key not in done:  # the BIM's and the detector's) is registered once: registration is deterministic
            done[key] = register(model_pts, model_normals, points_world, init=T, up=UP, upright_bias=bias,
                                 yaw_only=yaw_only, config=cfg, support_height=slab_height if resting else None,
                                 report=report)
        return done[key]

    refine = rules.refine_detector_pose and len(detector_poses) > 0
    starts = start_poses(model_pts, points_world, bim_pose, detector_poses, slab_height, refine)
    fits = [fit_from(T, local if refine else rules.icp) for T in starts]
    best = min([f for f in fits if plausible(f)] or fits, key=lambda f: f.score)
    if bim_pose is None:
        return best
    at_bim = fits[0] if refine else fit_from(bim_pose, local)
    return at_bim if at_bim.score <= rules.tie_ratio * best.score and plausible(at_bim) else best


def start_poses(model_pts: np.ndarray, points_world: np.ndarray, bim_pose: np.ndarray | None,
                detector_poses: Sequence[np.ndarray], slab_height: float, refine: bool) -> list[np.ndarray]:
    """Where SG-ICP starts (the BIM pose first, when there is one): see the module docs."""
    bim = [bim_pose] if bim_pose is not None else []
    if refine:
        return bim + list(detector_poses)
    home = slid(bim_pose, model_pts, points_world) if bim_pose is not None else \
        upright_on(points_world, model_pts, slab_height)
    return bim + [home] + list(detector_poses) + along_long_axis(home, model_pts, points_world)[1:]


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


def rests_on_slab(T: np.ndarray | None, model_pts: np.ndarray, slab_height: float, contact: float) -> bool:
    """Whether a model posed at ``T`` has its lowest point within ``contact`` m of the slab at ``slab_height``;
    with no pose to go by (``T`` None: an object the robot found, no detector pose) it is taken to stand on it."""
    if T is None:
        return True
    lowest = float(np.min(model_pts @ T[:3, :3].T[:, 2] + T[2, 3]))
    return abs(lowest - slab_height) <= contact
