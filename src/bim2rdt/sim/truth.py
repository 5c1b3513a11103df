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


@dataclass(frozen=True)
class PoseError:
    """Rotation error (deg, modulo symmetry), translation error of the body origin (m), and the angle between
    estimated and true upright axes (deg)."""

    rotation_deg: float
    translation: float
    tilt_deg: float

    def success(self, max_rotation_deg: float = 2.0, max_translation: float = 0.01) -> bool:
        return self.rotation_deg < max_rotation_deg and self.translation < max_translation


def pose_error(family: str, T_est: np.ndarray, T_true: np.ndarray) -> PoseError:
    """Errors of ``T_est`` against ``T_true`` (both T_world_model), modulo the family's symmetry."""
    tilt = float(np.rad2deg(np.arccos(np.clip(T_est[:3, 2] @ T_true[:3, 2], -1.0, 1.0))))
    order = SYMMETRY_ORDER.get(family, 1)
    if order == AXIAL:
        rotation = tilt
    else:
        turns = axis_angle(np.tile([0.0, 0.0, 1.0], (order, 1)), 2 * np.pi * np.arange(order) / order)
        relative = np.einsum("ij,kjl,ml->kim", T_est[:3, :3], turns, T_true[:3, :3])
        rotation = float(np.rad2deg(rotation_angle(relative).min()))
    return PoseError(rotation, float(np.linalg.norm(T_est[:3, 3] - T_true[:3, 3])), tilt)
