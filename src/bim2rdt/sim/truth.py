"""Ground-truth errors of an estimated pose, for scoring in the simulator and the benchmarks (never in the
mission): modulo the true symmetry of each simulated shape, so a drum turned about its own axis, a cone turned
by 90 degrees (square base), a pallet or I-beam by 180 degrees are not errors."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from bim2rdt.registration.so3 import rotation_angle
from bim2rdt.registration.symmetry import closest_equivalent

MESH_SYMMETRY: dict[str, float] = {
    "Traffic_Cone_Orange_70cm": 4,  # round body on a square base
    "Steel_Drum_55gal": math.inf,  # the 3 cm bung is below what sparse corners resolve
    "Wooden_Crate_1200x800x600": 1,  # the cleat on +x breaks the 180 degree symmetry
    "Pallet_Wood_EUR": 2,
    "Survey_Tripod_Aluminium": 1,  # the clamp marks one leg
    "Scaffold_Frame_1000x2000": 1,  # one diagonal brace
    "Steel_I-Beam_W12x26_A992": 2,
}
"""The true rotational order about body z of each procedural mesh of :mod:`bim2rdt.sim.meshes` (1 = none,
``math.inf`` = any turn): facts of the simulator's own shapes, used only to score. The mission judges with the
family's prior (``UprightPrior.symmetry``), which may allow more (a crate prior says 2: most crates are plain
boxes; this one has a cleat), never less: the true symmetry group must be part of the prior's."""


def true_symmetry(family: str, prior_symmetry: float | None = None) -> float:
    """The order to score ``family`` with: the simulated mesh's own, else the prior's (a BIM body the simulator
    did not build), else 1."""
    if family in MESH_SYMMETRY:
        return MESH_SYMMETRY[family]
    return 1 if prior_symmetry is None else prior_symmetry


FAILURE_MODES = ("ok", "tilt", "flip", "yaw", "slide")
"""How a registration ended, by the first bar it misses (rotation 2 deg, translation 1 cm, modulo symmetry):
``tilt`` the upright axis is off (what a gravity prior can fix); ``flip`` upright but turned by >= 90 degrees
about it (a wrong-yaw minimum of a near-symmetric shape, e.g. a crate whose marking face is not seen); ``yaw``
upright but turned by 2-90 degrees; ``slide`` the rotation is right but the position is off (sliding along a
featureless face, a partial view). Neither of the last three is observable by gravity."""


@dataclass(frozen=True)
class PoseError:
    """Rotation error (deg, modulo symmetry), translation error of the body origin (m), and the angle between
    estimated and true upright axes (deg)."""

    rotation_deg: float
    translation: float
    tilt_deg: float

    def success(self, max_rotation_deg: float = 2.0, max_translation: float = 0.01) -> bool:
        return self.rotation_deg < max_rotation_deg and self.translation < max_translation

    def failure_mode(self, max_rotation_deg: float = 2.0, max_translation: float = 0.01) -> str:
        """Why a registration failed, first cause first (see :data:`FAILURE_MODES`)."""
        if self.success(max_rotation_deg, max_translation):
            return "ok"
        if self.tilt_deg >= max_rotation_deg:
            return "tilt"
        if self.rotation_deg >= 90.0:
            return "flip"
        return "yaw" if self.rotation_deg >= max_rotation_deg else "slide"


def pose_error(family: str, T_est: np.ndarray, T_true: np.ndarray,
               prior_symmetry: float | None = None) -> PoseError:
    """Errors of ``T_est`` against ``T_true`` (both T_world_model), modulo the family's true symmetry
    (:func:`true_symmetry`)."""
    tilt = float(np.rad2deg(np.arccos(np.clip(T_est[:3, 2] @ T_true[:3, 2], -1.0, 1.0))))
    closest = closest_equivalent(T_est, T_true, true_symmetry(family, prior_symmetry))
    rotation = float(np.rad2deg(rotation_angle(closest[:3, :3] @ T_true[:3, :3].T)))
    return PoseError(rotation, float(np.linalg.norm(T_est[:3, 3] - T_true[:3, 3])), tilt)


MATCH_DISTANCE = 0.5
"""Farthest (m) an observation's body origin may lie from a true object's to be scored against it."""


def match_truth(found: Sequence[tuple[str, np.ndarray]], truth: Sequence[tuple[str, np.ndarray]],
                max_distance: float = MATCH_DISTANCE) -> list[int | None]:
    """Which true object each found one is, by geometry alone (the mission never knows): pairs of the same family
    (``(family, T_world_model)`` each) taken closest first, one to one, within ``max_distance``. Returns the index
    into ``truth`` per found object, None for one that matches nothing (a phantom)."""
    pairs = sorted((float(np.linalg.norm(T[:3, 3] - T_true[:3, 3])), i, j)
                   for i, (family, T) in enumerate(found) for j, (true_family, T_true) in enumerate(truth)
                   if family == true_family)
    matched: list[int | None] = [None] * len(found)
    taken: set[int] = set()
    for distance, i, j in pairs:
        if distance <= max_distance and matched[i] is None and j not in taken:
            matched[i] = j
            taken.add(j)
    return matched
