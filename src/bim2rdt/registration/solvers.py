"""The rigid solve of one ICP step (Algorithm 1: SolveRigid + ApplyBias + ProjectYawIf), batched over restarts.

Both solvers see scene points already moved into the body (model) frame, ``src`` (k, N, 3), paired with model
points ``dst`` (k, N, 3) and normals, with robust weights ``w`` (k, N). They return the body-frame step
(dR, dt) that maps src onto dst; the caller composes ``T_new = T @ inv([dR, dt])``.

The gravity bias is one more weighted correspondence: the world up seen in the body frame ``g_src`` (k, 3)
should land on the body's upright axis ``g_dst`` (3,), with weight ``lam`` (k,). Because
|R g_src - g_dst|^2 = 2 - 2 g_dst^T R g_src, adding lam |R g_src - g_dst|^2 to the cost is exactly
H += lam g_src g_dst^T in Kabsch, and the residual sqrt(lam)(R g_src - g_dst) with Jacobian
-sqrt(lam) [g_src]x in Gauss-Newton. ``yaw_only`` restricts the step to a rotation about ``g_src`` (roll and
pitch stay where the initial pose put them).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from bim2rdt.registration.matching import Pairs
from bim2rdt.registration.so3 import axis_angle, exp_so3, skew


def weighted_centroids(points: np.ndarray, w: np.ndarray) -> np.ndarray:
    """(k, N, 3), (k, N) -> (k, 3)."""
    return (w[:, None, :] @ points)[:, 0] / np.maximum(w.sum(axis=1), 1e-300)[:, None]


def gravity_weight(dst: np.ndarray, w: np.ndarray, bias_gamma: float) -> np.ndarray:
    """Scale-free lambda = beta * gamma0 * sum(w |p - p_mean|^2): the same meaning for a 30 cm cone and a 3 m
    column, because the data term's rotational stiffness grows with the same sum. (k,)"""
    centred = dst - weighted_centroids(dst, w)[:, None, :]
    return bias_gamma * np.einsum("kn,kn->k", w, np.einsum("kni,kni->kn", centred, centred))


def solve_point_to_point(src, dst, w, g_src, g_dst, lam, yaw_only=False):
    """Weighted Kabsch with the gravity correspondence; exact 4-DoF optimum when ``yaw_only``.

    Maximises tr(R H) with H = sum w s~ d~^T + lam g_src g_dst^T. Returns dR (k, 3, 3), dt (k, 3).
    """
    s_mean, d_mean = weighted_centroids(src, w), weighted_centroids(dst, w)
    H = np.swapaxes((src - s_mean[:, None]) * w[..., None], 1, 2) @ (dst - d_mean[:, None])
    H = H + lam[:, None, None] * np.einsum("ki,j->kij", g_src, g_dst)
    dR = _yaw_kabsch(H, g_src) if yaw_only else _kabsch(H)
    return dR, d_mean - np.einsum("kij,kj->ki", dR, s_mean)


def _kabsch(H: np.ndarray) -> np.ndarray:
    U, _, Vt = np.linalg.svd(H)
    V = np.swapaxes(Vt, -1, -2)
    d = np.sign(np.linalg.det(V @ np.swapaxes(U, -1, -2)))
    D = np.zeros_like(H)
    D[:, 0, 0], D[:, 1, 1], D[:, 2, 2] = 1.0, 1.0, np.where(d == 0, 1.0, d)
    return V @ D @ np.swapaxes(U, -1, -2)


def _yaw_kabsch(H: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """argmax over theta of tr(R(axis, theta) H): theta = atan2(tr([a]x H), tr H - a^T H a)."""
    sin_term = np.einsum("kij,kji->k", skew(axis), H)
    cos_term = np.trace(H, axis1=1, axis2=2) - np.einsum("ki,kij,kj->k", axis, H, axis)
    return axis_angle(axis, np.arctan2(sin_term, cos_term))


def solve_point_to_plane(src, dst, normals, w, g_src, g_dst, lam, yaw_only=False):
    """One Gauss-Newton step on sum w (n . (dR s + dt - d))^2 + lam |dR g_src - g_dst|^2, dR ~ I + [omega]x.

    Returns dR = exp(omega) (k, 3, 3), dt (k, 3). Degenerate views (one visible plane) are solved by solution
    remapping (X-ICP, Zhang et al. 2016): the step is taken only along eigen-directions of the normal matrix
    (rotation scaled by its lever arm, :func:`_unit_scales`) whose stiffness is at least
    :data:`DEGENERATE_RATIO` of the stiffest; the others do not move. A ridge alone is not enough: a pallet
    deck seen from above (all normals up) plus the resting-contact pair leaves in-plane directions with ~1e-7
    of the stiffness, and the contact pair's mismatch along them sent the pose 1.4 m away in one step.
    """
    r = np.einsum("kni,kni->kn", normals, src - dst)
    J = np.empty(src.shape[:2] + (6,))  # (k, N, 6): d r / d (omega, dt)
    _cross(src, normals, out=J[..., :3])
    J[..., 3:] = normals
    Jw_t = np.swapaxes(J * w[..., None], 1, 2)  # (k, 6, N)
    A = Jw_t @ J
    b = -(Jw_t @ r[..., None])[..., 0]
    Jg = -skew(g_src)  # d(dR g_src)/d omega
    A[:, :3, :3] += lam[:, None, None] * np.einsum("kji,kjl->kil", Jg, Jg)
    b[:, :3] -= lam[:, None] * np.einsum("kji,kj->ki", Jg, g_src - g_dst)
    return solve_system(A, b, g_src, yaw_only)


def solve_system(A: np.ndarray, b: np.ndarray, g_src: np.ndarray, yaw_only: bool = False):
    """The point-to-plane step from its normal equations A (k, 6, 6), b (k, 6) (rotation, then translation;
    gravity term included), by solution remapping (see :func:`solve_point_to_plane`); with ``yaw_only`` only the
    rotation about ``g_src`` (k, 3) and the translations move. Returns dR = exp(omega) (k, 3, 3), dt (k, 3)."""
    if not yaw_only:  # the full basis is the identity: solve in place (the same numbers, a third of the work)
        x = _remapped_solve(A, b, _unit_scales(_FULL_ROTATIONAL, A))
        return exp_so3(x[:, :3]), x[:, 3:]
    basis = _step_basis(g_src, yaw_only)  # (k, 6, m)
    A_r = np.swapaxes(basis, 1, 2) @ A @ basis
    b_r = np.einsum("kim,ki->km", basis, b)
    rotational = np.linalg.norm(basis[:, :3, :], axis=1) > 0.0  # (k, m)
    x = np.einsum("kim,km->ki", basis, _remapped_solve(A_r, b_r, _unit_scales(rotational, A)))
    return exp_so3(x[:, :3]), x[:, 3:]


def _cross(a: np.ndarray, b: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """Cross products along the last axis (..., 3): np.cross's own arithmetic, without its axis shuffling;
    written into ``out`` when given."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape)) if out is None else out
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    np.subtract(a1 * b2, a2 * b1, out=out[..., 0])
    np.subtract(a2 * b0, a0 * b2, out=out[..., 1])
    np.subtract(a0 * b1, a1 * b0, out=out[..., 2])
    return out


_FULL_ROTATIONAL = np.array([[True] * 3 + [False] * 3])
"""Which coordinates of the 6-DoF step rotate (1, 6), for :func:`_unit_scales`."""


DEGENERATE_RATIO = 1e-6
"""Eigen-directions of the (scaled) normal matrix with less than this share of the stiffest one's eigenvalue do
not move in a point-to-plane step: the data cannot tell where they should go (see :func:`solve_point_to_plane`).
The pallet deck's are at 1.6e-7. At 1e-5 the demo's frame 2 gained a phantom new tripod: 132 points of the
beam's view (129 of them on Column C11's vertical corner) that a tripod leg fits to 1.4 mm once it cannot run
off along itself, a fit the old solve lost by diverging; the mission now rejects it on purpose, naming the
column (:mod:`bim2rdt.mission.explained`; the hop grid finds the same fit at 1e-6)."""


def _unit_scales(rotational: np.ndarray, A: np.ndarray) -> np.ndarray:
    """Per step coordinate (k, m): 1 / L for rotational coordinates (``rotational`` (k or 1, m) True), 1 for
    translations, with L (m) the lever arm of the 6-DoF system ``A``'s own rotational stiffness,
    sqrt(tr A_rot / tr A_trans), so that eigenvalues compare a radian at the object's edge with a metre."""
    lever = np.sqrt(np.trace(A[:, :3, :3], axis1=1, axis2=2)
                    / np.maximum(np.trace(A[:, 3:, 3:], axis1=1, axis2=2), 1e-300))
    return np.where(rotational, 1.0 / np.maximum(lever, 1e-6)[:, None], 1.0)


def _remapped_solve(A: np.ndarray, b: np.ndarray, scales: np.ndarray) -> np.ndarray:
    """Solve A x = b (k, m, m), (k, m) in the well-determined eigen-directions of the scaled system only.

    Systems whose every eigen-direction is kept are solved directly (:func:`_well_determined`: a batched
    Cholesky test, a thirtieth of the batched ``eigh``'s time; the same solution to round-off), the others by
    their eigen-decomposition."""
    A_s = scales[:, :, None] * A * scales[:, None, :]
    sure = _well_determined(A_s)
    if sure.all():
        return scales * np.linalg.solve(A_s, (scales * b)[..., None])[..., 0]
    x = np.empty_like(b)
    if sure.any():
        x[sure] = scales[sure] * np.linalg.solve(A_s[sure], (scales[sure] * b[sure])[..., None])[..., 0]
    rest = ~sure
    x[rest] = _eigen_solve(A_s[rest], b[rest], scales[rest])
    return x


def _well_determined(A_s: np.ndarray) -> np.ndarray:
    """(k,) True where every eigenvalue of the symmetric systems (k, m, m) surely exceeds
    :data:`DEGENERATE_RATIO` x the largest: A_s - tau I is positive definite (its Cholesky factor exists) for
    tau = DEGENERATE_RATIO x trace(A_s), which is at least that share of the largest eigenvalue. False is only
    'not sure' (the eigen-decomposition decides)."""
    tau = DEGENERATE_RATIO * np.trace(A_s, axis1=1, axis2=2)
    shifted = A_s - tau[:, None, None] * np.eye(A_s.shape[-1])
    try:
        np.linalg.cholesky(shifted)
        return tau > 0.0
    except np.linalg.LinAlgError:
        pass
    sure = tau > 0.0
    for i in np.flatnonzero(sure):
        try:
            np.linalg.cholesky(shifted[i])
        except np.linalg.LinAlgError:
            sure[i] = False
    return sure


def _eigen_solve(A_s: np.ndarray, b: np.ndarray, scales: np.ndarray) -> np.ndarray:
    """:func:`_remapped_solve` by the eigen-decomposition of the scaled systems ``A_s`` (k, m, m)."""
    values, vectors = np.linalg.eigh(A_s)
    kept = values > DEGENERATE_RATIO * np.maximum(values[:, -1:], 1e-300)
    along = np.einsum("kmj,km->kj", vectors, scales * b)
    y = np.einsum("kmj,kj->km", vectors, np.where(kept, along / np.where(kept, values, 1.0), 0.0))
    return scales * y


def _step_basis(g_src: np.ndarray, yaw_only: bool) -> np.ndarray:
    """Columns spanning the allowed steps: all 6 DoF, or (rotation about g_src, 3 translations)."""
    k = len(g_src)
    if not yaw_only:
        return np.broadcast_to(np.eye(6), (k, 6, 6))
    basis = np.zeros((k, 6, 4))
    basis[:, :3, 0] = g_src
    basis[:, 3:, 1:] = np.eye(3)
    return basis


def _point_to_point_step(src, dst, normals, w, g_src, g_dst, lam, yaw_only=False):
    """Point-to-point as a strategy with the point-to-plane signature (the normals are not used)."""
    return solve_point_to_point(src, dst, w, g_src, g_dst, lam, yaw_only)


@dataclass(frozen=True)
class Solver:
    """A rigid-solve strategy: the step, and which pair residual its robust weights should see (the quantity
    the step minimises: distance to the sample for point-to-point, to the surface for point-to-plane)."""

    step: Callable[..., tuple[np.ndarray, np.ndarray]]
    residual: Callable[[Pairs, float], np.ndarray]  # (pairs, model sample spacing in m) -> (k, N) m


SOLVERS = {
    # point-to-point minimises the distance to a sample, which is up to ~the spacing even at the optimum
    "point_to_point": Solver(_point_to_point_step,
                             lambda pairs, spacing: np.maximum(pairs.distance - spacing, 0.0)),
    "point_to_plane": Solver(solve_point_to_plane, lambda pairs, spacing: pairs.residual),
}
"""Strategy per ``IcpConfig.method``; steps take (src, dst, normals, w, g_src, g_dst, lam, yaw_only)."""
