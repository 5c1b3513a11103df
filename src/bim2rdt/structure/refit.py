"""The pose fixed on the other elements: a 4-DoF point-to-plane refit (x, y, z and the turn about up, the IMU
keeps roll and pitch, as the localization does) of one view's returns on the model faces, leaving one element's
returns out, so that element cannot pull the pose onto itself (decision 0032).

The pairs are the rays' (a return and the model face its ray hits), fixed; residuals ``rho = n . (p - q)`` with ``n``
turned towards the sensor, so ``rho > 0`` is a return in front of its face. The refit is linear in the correction
(x, y, z, yaw at the sensor) and reweighted by Huber's weights a few times.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

UP = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class Pairs:
    """One view's returns on model faces: ``rho`` (K,) signed distances, m; ``jacobian`` (K, 4) of ``rho`` by the
    correction (dx, dy, dz m, dyaw rad about the sensor); ``normal`` (K, 3) unit towards the sensor; ``element``
    (K,) the face's element; ``fixes`` (K,) whether the pair may fix the pose (its element is in the map)."""

    rho: np.ndarray
    jacobian: np.ndarray
    normal: np.ndarray
    element: np.ndarray
    fixes: np.ndarray

    @classmethod
    def of(cls, points_world: np.ndarray, model_points: np.ndarray, normals: np.ndarray, element: np.ndarray,
           fixes: np.ndarray, centre: np.ndarray) -> Pairs:
        """The pairs of returns ``points_world`` (K, 3) and their faces' points ``model_points`` (K, 3) and
        ``normals`` (K, 3, towards the sensor at ``centre``), metres.

        Args:
            points_world: The returns placed by the view's pose.
            model_points: Where each return's ray meets its model face.
            normals: The faces' unit normals, towards the sensor.
            element: Each face's element index.
            fixes: Whether each pair may fix the pose.
            centre: The sensor's position (3,), the yaw's pivot.

        Returns:
            The pairs.
        """
        rho = np.einsum("ni,ni->n", normals, points_world - model_points)
        lever = np.cross(UP, points_world - centre)
        jacobian = np.column_stack([normals, np.einsum("ni,ni->n", normals, lever)])
        return cls(rho, jacobian, normals, element, fixes)


def refit(pairs: Pairs, keep: np.ndarray, huber: float, iterations: int = 6,
          weights: np.ndarray | None = None) -> np.ndarray:
    """The correction (dx, dy, dz, dyaw) that best puts the ``keep`` pairs on their faces (Huber-weighted least
    squares, m and rad; zero along what they do not constrain).

    Args:
        pairs: The view's pairs.
        keep: (K,) bool, the pairs that may fix the pose.
        huber: Huber scale, m.
        iterations: Reweighting passes.
        weights: (K,) each pair's weight before Huber's (None: 1).

    Returns:
        (4,) the correction.
    """
    J, rho = pairs.jacobian[keep], pairs.rho[keep]
    base = np.ones(len(rho)) if weights is None else weights[keep]
    x = np.zeros(4)
    if len(rho) < 6:
        return x
    for _ in range(iterations):
        r = np.abs(rho + J @ x)
        w = base * np.minimum(1.0, huber / np.maximum(r, 1e-12))
        H = J.T @ (J * w[:, None])
        damping = 1e-9 * max(np.trace(H), 1e-12) * np.eye(4)
        x = -np.linalg.lstsq(H + damping, J.T @ (w * rho), rcond=1e-8)[0]
    return x


def pin_weight(pairs: Pairs, keep: np.ndarray, normal: np.ndarray, huber: float) -> float:
    """How many of the ``keep`` pairs face along ``normal`` (each weighted by its cosine squared with it, and by
    Huber's weight at the uncorrected pose): how well they pin the pose along it.

    Args:
        pairs: The view's pairs.
        keep: (K,) bool, the pairs that fix the pose.
        normal: (3,) unit.
        huber: Huber scale, m.

    Returns:
        The weight, in returns.
    """
    w = np.minimum(1.0, huber / np.maximum(np.abs(pairs.rho[keep]), 1e-12))
    return float(np.sum(w * (pairs.normal[keep] @ normal) ** 2))


def consensus(pairs: Pairs, tolerance: dict[int, float], huber: float, min_points: int, min_pin: float) -> np.ndarray:
    """The elements the pose is fixed on: every map element with ``min_points`` pairs, each weighing the same
    (its pairs weighted by one over their number), the worst one left out while it lies beyond its
    ``tolerance`` (m, by element) from the pose the others give and every face direction of it stays pinned by
    two other elements (``min_pin`` weighted pairs each): a wall built off its line is outvoted when enough
    other surfaces face its way, never by a single one (two disagreeing elements cannot tell which moved).

    Args:
        pairs: The view's pairs.
        tolerance: {element index: its tolerance, m}.
        huber: Huber scale, m.
        min_points: Fewer pairs than this, and an element takes no part.
        min_pin: Weighted pairs that make an element pin a direction.

    Returns:
        (K,) bool, the pairs of the consensus elements.
    """
    if len(pairs.rho) == 0:
        return np.zeros(0, bool)
    elements, counts = np.unique(pairs.element[pairs.fixes], return_counts=True)
    members = {int(e) for e, n in zip(elements, counts) if n >= min_points}
    weights = 1.0 / np.maximum(np.bincount(pairs.element, minlength=pairs.element.max() + 1)[pairs.element], 1)
    while len(members) > 2:
        keep = np.isin(pairs.element, list(members)) & pairs.fixes
        x = refit(pairs, keep, huber, weights=weights)
        off = {e: abs(float(np.median(pairs.rho[pairs.element == e] + pairs.jacobian[pairs.element == e] @ x)))
               / tolerance.get(e, huber) for e in members}
        worst = max(off, key=off.get)
        if off[worst] <= 1.0 or not _still_pinned(pairs, worst, members - {worst}, min_points, min_pin):
            break
        members.discard(worst)
    return np.isin(pairs.element, list(members)) & pairs.fixes


def _still_pinned(pairs: Pairs, element: int, others: set[int], min_points: int, min_pin: float) -> bool:
    """Whether each face direction of ``element`` (``min_points`` pairs) is pinned by two of ``others``."""
    mine = pairs.element == element
    groups = np.round(pairs.normal[mine] * 10).astype(int)
    for key in {tuple(g) for g in groups.tolist()}:
        face = np.all(groups == key, axis=1)
        if face.sum() < min_points:
            continue
        normal = pairs.normal[mine][face].mean(axis=0)
        pinning = sum(pin_weight(pairs, pairs.element == other, normal / np.linalg.norm(normal), 1e9) >= min_pin
                      for other in others)
        if pinning < 2:
            return False
    return True
