"""Ground-truth errors of an estimated pose, aware of each family's true symmetries: a drum turned about its own
axis, a cone turned by 90 degrees (square base), a pallet or I-beam by 180 degrees are not errors."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bim2rdt.registration.so3 import axis_angle, rotation_angle

AXIAL = 0
"""Symmetry order meaning 'any rotation about the body z axis'."""

SYMMETRY_ORDER: dict[str, int] = {
    "Traffic_Cone_Orange_70cm": 4,  # round body on a square base
    "Steel_Drum_55gal": AXIAL,  # the 3 cm bung is below what sparse corners resolve
    "Wooden_Crate_1200x800x600": 1,  # the cleat on +x breaks the 180 degree symmetry
    "Pallet_Wood_EUR": 2,
    "Survey_Tripod_Aluminium": 1,  # the clamp marks one leg
    "Scaffold_Frame_1000x2000": 1,  # one diagonal brace
    "Steel_I-Beam_W12x26_A992": 2,
}
"""Order n of each family's rotational symmetry about its body z axis (1 = none)."""


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


def pose_error(family: str, T_est: np.ndarray, T_true: np.ndarray, order: int | None = None) -> PoseError:
    """Errors of ``T_est`` against ``T_true`` (both T_world_model), modulo the family's symmetry (``order``
    overrides the family's, for shapes outside :data:`SYMMETRY_ORDER`)."""
    tilt = float(np.rad2deg(np.arccos(np.clip(T_est[:3, 2] @ T_true[:3, 2], -1.0, 1.0))))
    closest = closest_equivalent(family, T_est, T_true, order)
    rotation = float(np.rad2deg(rotation_angle(closest[:3, :3] @ T_true[:3, :3].T)))
    return PoseError(rotation, float(np.linalg.norm(T_est[:3, 3] - T_true[:3, 3])), tilt)


def closest_equivalent(family: str, T_est: np.ndarray, T_true: np.ndarray, order: int | None = None) -> np.ndarray:
    """The pose that shows the same object as ``T_est`` (turned about its body z axis by a symmetry of the
    family) and is closest in rotation to ``T_true``. Metrics on fixed surface samples then measure the surface
    error, not the sampling: a drum turned by 10 degrees about its axis puts every sample somewhere else, on
    the same surface."""
    order = SYMMETRY_ORDER.get(family, 1) if order is None else order
    M = T_true[:3, :3].T @ T_est[:3, :3]
    if order == AXIAL:  # argmax over theta of tr(M Rz(theta))
        angles = np.array([np.arctan2(M[0, 1] - M[1, 0], M[0, 0] + M[1, 1])])
    else:
        angles = 2 * np.pi * np.arange(order) / order
    turns = axis_angle(np.tile([0.0, 0.0, 1.0], (len(angles), 1)), angles)
    best = turns[int(np.argmax(np.trace(M @ turns, axis1=1, axis2=2)))]
    out = T_est.copy()
    out[:3, :3] = T_est[:3, :3] @ best
    return out
