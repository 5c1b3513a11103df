"""Alignment metrics: the paper's Hausdorff statistics between two point sets (e.g. a mesh's surface samples
at the estimated pose and at the true pose)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from bim2rdt.registration.errors import RegistrationError


@dataclass(frozen=True)
class HausdorffStats:
    """Nearest-neighbour distances from A to B and from B to A, pooled: root mean square, mean, and maximum
    (the last is the symmetric Hausdorff distance). Metres."""

    rmse: float
    mean: float
    max: float


def hausdorff(points_a: np.ndarray, points_b: np.ndarray) -> HausdorffStats:
    """Symmetric nearest-distance statistics of two point sets in the same frame.

    Args:
        points_a: (N,3) points, metres.
        points_b: (M,3) points, metres.

    Returns:
        RMSE, mean and maximum (the symmetric Hausdorff distance) of the pooled A-to-B and B-to-A nearest
            distances, metres.

    Raises:
        RegistrationError: A set is not (N,3) with N >= 1, or holds NaN or infinite values.
    """
    a, b = _cloud("points_a", points_a), _cloud("points_b", points_b)
    d_ab, _ = cKDTree(b).query(a)
    d_ba, _ = cKDTree(a).query(b)
    d = np.concatenate([d_ab, d_ba])
    return HausdorffStats(rmse=float(np.sqrt(np.mean(d**2))), mean=float(d.mean()), max=float(d.max()))


def _cloud(name: str, points) -> np.ndarray:
    array = np.asarray(points, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != 3 or len(array) == 0:
        raise RegistrationError(f"{name} must have shape (N, 3) with N >= 1, got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise RegistrationError(f"{name} contains NaN or infinite values")
    return array
