"""How well point-to-plane pairs fix a rigid pose: information, covariance, and the directions a view cannot
constrain (a single long wall leaves the position along it free; a bare slab leaves x, y and yaw free).

Pure numpy on plain arrays, so any registration can use it (the localizer for a camera, SG-ICP for an object).

The pose error is a small world-frame motion xi = (dt, dtheta) (6,): a point p of the moving body goes to
p + dtheta x (p - c) + dt, a turn about the centre c (the camera centre, an object's centroid) and a shift. A
pair (p on the body, q on the surface with unit normal n) has the residual n . (p - q), whose Jacobian is
J = [n, (p - c) x n]; the information of the pairs is sum w J J^T (1/m^2 when w is 1/sigma^2).

A direction is degenerate when the pairs pin it no better than ``max_sigma`` (1 sigma, m), rotations measured in
metres at the pairs' lever arm: the eigenvalue test of Zhang, Kaess & Singh 2016 ("On degeneracy of
optimization-based state estimation problems") with an absolute threshold. A threshold relative to the strongest
direction flags too much: the slab always constrains height by far the most, and a view of a column and a
distant wall that pins its weakest direction to 3 cm came out 'degenerate' at 1 % of it. The covariance is the
inverse along what the view constrains and ``unconstrained_sigma`` squared along what it does not, so it is
large exactly where the view is blind.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

IN_SUBSPACE = 0.5
"""A free direction is reported as a shift when its shift part has at least this norm, as a turn likewise."""


@dataclass(frozen=True)
class Observability:
    """``covariance`` (6, 6) and ``information`` (6, 6, zero along degenerate directions) of xi = (dt, dtheta)
    (m, rad; world axes); the unit world directions of translation and axes of rotation the pairs leave free."""

    covariance: np.ndarray
    information: np.ndarray
    degenerate_translations: list[np.ndarray] = field(default_factory=list)
    degenerate_rotations: list[np.ndarray] = field(default_factory=list)


def pair_information(points: np.ndarray, normals: np.ndarray, centre: np.ndarray,
                     weights: np.ndarray | None = None) -> np.ndarray:
    """sum w J J^T (6, 6) of point-to-plane pairs: body points (N, 3) and their surfaces' unit normals (N, 3),
    world metres, turning about ``centre`` (3,); ``weights`` (N,) default 1."""
    J = np.concatenate([normals, np.cross(points - centre, normals)], axis=1)
    w = np.ones(len(J)) if weights is None else np.asarray(weights, dtype=float)
    return (J * w[:, None]).T @ J


def lever_arm(points: np.ndarray, centre: np.ndarray) -> float:
    """Root-mean-square distance of the points from the centre, m: how far a turn of 1 rad moves them."""
    return float(np.sqrt(np.mean(np.sum((points - centre) ** 2, axis=1)))) if len(points) else 1.0


def observability(information: np.ndarray, length: float, max_sigma: float = 0.1, basis: np.ndarray | None = None,
                  unconstrained_sigma: float = 100.0) -> Observability:
    """Split ``information`` (6, 6, of xi) into what it constrains and what it leaves free.

    ``information`` is an inverse covariance (1/m^2, 1/rad^2). ``length`` (m) is the lever arm that makes a turn
    comparable with a shift; ``max_sigma`` (m) the loosest a direction may be pinned and still count as
    constrained; ``basis`` (6, m) spans the
    motions being estimated (None = all six; a yaw-only fix is x, y, z and the turn about up): motions outside it
    are held by something else (an IMU) and get no variance here. Free directions are pure shifts or pure turns
    (a weak mode that mixes both is assigned to the larger part); what remains is constrained, with the
    information left after the free directions are marginalised out (a Schur complement), so nothing is claimed
    through a coupling with a free direction. Along free directions the variance is ``unconstrained_sigma``
    squared (m^2, or rad^2 x length^2 for turns)."""
    scale = np.r_[np.ones(3), np.full(3, max(length, 1e-6))]  # y = scale * xi: turns in metres at the lever arm
    B = _orthonormal(scale[:, None] * (np.eye(6) if basis is None else np.asarray(basis, dtype=float)))
    A = B.T @ (information / np.outer(scale, scale)) @ B
    floor = 1.0 / max_sigma**2
    free = np.zeros((len(A), 0))
    for _ in range(len(A)):  # each round frees at least one more direction
        kept, A_kept = _marginal(A, free)
        values, vectors = np.linalg.eigh(A_kept)
        if kept.shape[1] == 0 or values.min() > floor:
            break
        free = _orthonormal(np.hstack([free, _pure(B, kept @ vectors[:, 0])[:, None]]))
    kept, A_kept = _marginal(A, free)
    cov_y = B @ (kept @ _pinv_psd(A_kept, A) @ kept.T + unconstrained_sigma**2 * free @ free.T) @ B.T
    info_y = B @ kept @ A_kept @ kept.T @ B.T
    free_y = B @ free
    return Observability(cov_y / np.outer(scale, scale), info_y * np.outer(scale, scale),
                         [_canonical(v[:3]) for v in free_y.T if np.linalg.norm(v[:3]) > IN_SUBSPACE],
                         [_canonical(v[3:]) for v in free_y.T if np.linalg.norm(v[3:]) > IN_SUBSPACE])


def _marginal(A: np.ndarray, free: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(basis of the complement of ``free``, the information on it with the free directions marginalised)."""
    if free.shape[1] == 0:
        return np.eye(len(A)), A
    complement = np.linalg.svd(np.eye(len(A)) - free @ free.T)[0][:, :len(A) - free.shape[1]]
    cross = complement.T @ A @ free
    return complement, complement.T @ A @ complement - cross @ _pinv_psd(free.T @ A @ free, A) @ cross.T


def _pinv_psd(block: np.ndarray, whole: np.ndarray) -> np.ndarray:
    """Pseudo-inverse of a PSD ``block`` of ``whole`` that treats eigenvalues below 1e-9 of the whole's largest
    as zero: rounding noise on a truly free direction must not be inverted into a huge number."""
    values, vectors = np.linalg.eigh(0.5 * (block + block.T))
    keep = values > 1e-9 * max(float(np.abs(whole).max()), 1e-300)
    return vectors[:, keep] @ np.diag(1.0 / values[keep]) @ vectors[:, keep].T


def _pure(B: np.ndarray, mode: np.ndarray) -> np.ndarray:
    """A weak mode (basis coordinates) as a pure shift or a pure turn, whichever part is larger, in basis
    coordinates (unit)."""
    y = B @ mode
    part = np.r_[y[:3], np.zeros(3)] if np.linalg.norm(y[:3]) >= np.linalg.norm(y[3:]) else np.r_[np.zeros(3), y[3:]]
    coordinates = B.T @ part
    return coordinates / np.linalg.norm(coordinates)


def _orthonormal(columns: np.ndarray) -> np.ndarray:
    q, _ = np.linalg.qr(columns)
    return q


def _canonical(v: np.ndarray) -> np.ndarray:
    """The unit vector with its largest component positive (a direction, not an orientation)."""
    v = v / np.linalg.norm(v)
    return v if v[np.argmax(np.abs(v))] > 0 else -v
