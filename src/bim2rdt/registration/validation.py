"""Checks at the edge of :func:`register`: shapes, finiteness, enough points, a rigid initial pose."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bim2rdt.frames import rigid_problem
from bim2rdt.registration.errors import RegistrationError

MIN_SCENE_POINTS = 6
"""Fewer points cannot pin down 6 degrees of freedom robustly (Algorithm 1: require |S| >= 6)."""


@dataclass(frozen=True)
class Problem:
    """Validated, float64 inputs of one registration."""

    model_pts_body: np.ndarray  # (M, 3)
    model_normals_body: np.ndarray  # (M, 3), unit
    scene_pts_world: np.ndarray  # (N, 3)
    T_world_model_init: np.ndarray  # (4, 4)
    up_world: np.ndarray  # (3,), unit
    upright_bias: float
    support_height: float | None = None  # m along up_world: the slab the object rests on, when known


def validate_problem(model_points, model_normals, scene_points, init, up, upright_bias,
                     support_height=None) -> Problem:
    """Turn raw inputs into a :class:`Problem` or raise :class:`RegistrationError` naming the bad argument."""
    model = _points("model_points", model_points)
    normals = _points("model_normals", model_normals)
    scene = _points("scene_points", scene_points)
    if normals.shape != model.shape:
        raise RegistrationError(f"model_normals has shape {normals.shape}, expected {model.shape} like model_points")
    if len(scene) < MIN_SCENE_POINTS:
        raise RegistrationError(f"scene_points has {len(scene)} points, need at least {MIN_SCENE_POINTS}")
    if len(model) < MIN_SCENE_POINTS:
        raise RegistrationError(f"model_points has {len(model)} points, need at least {MIN_SCENE_POINTS}")
    lengths = np.linalg.norm(normals, axis=1)
    if np.any(lengths < 1e-9):
        raise RegistrationError("model_normals contains zero-length normals")
    bias = float(upright_bias)
    if not 0.0 <= bias <= 1.0:
        raise RegistrationError(f"upright_bias must be in [0, 1], got {bias}")
    support = None if support_height is None else float(support_height)
    if support is not None and not np.isfinite(support):
        raise RegistrationError(f"support_height must be a finite height in metres or None, got {support}")
    return Problem(model, normals / lengths[:, None], scene, _rigid_pose(init), unit_up(up), bias, support)


def _points(name: str, values) -> np.ndarray:
    array = np.asarray(values, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != 3:
        raise RegistrationError(f"{name} must have shape (N, 3), got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise RegistrationError(f"{name} contains NaN or infinite values")
    return array


def _rigid_pose(init) -> np.ndarray:
    problem = rigid_problem(init)
    if problem is not None:
        raise RegistrationError(f"init is not rigid: {problem}")
    return np.asarray(init, dtype=np.float64)


def unit_up(up: np.ndarray | tuple[float, float, float]) -> np.ndarray:
    """``up`` as a unit 3-vector.

    Args:
        up: The world up as measured (an IMU's), any length.

    Returns:
        It, normalised.

    Raises:
        RegistrationError: It is not a finite non-zero 3-vector (one line).
    """
    vector = np.asarray(up, dtype=np.float64).reshape(-1)
    if vector.shape != (3,) or not np.all(np.isfinite(vector)) or np.linalg.norm(vector) < 1e-9:
        raise RegistrationError(f"up must be a finite non-zero 3-vector, got {np.asarray(up).tolist()}")
    return vector / np.linalg.norm(vector)
