"""One ICP step's arithmetic around the k-d tree query, compiled (numba): the scene in each restart's body frame,
the pairs' residuals and score, trimming, Huber weights, the gravity weight, the point-to-plane normal equations
and their remapped solve, for every restart in one call each.

The numpy path (:func:`bim2rdt.registration.icp._weighted_pairs` and :func:`bim2rdt.registration.solvers.
solve_point_to_plane`) costs ~40 numpy calls an iteration on arrays of a few hundred to a few thousand points,
so its time is mostly per-call overhead (decision 0040). These kernels do the same arithmetic in a pass per
restart. Sums run in another order than numpy's, so results agree with the numpy path to round-off (~1e-15
relative), not bit for bit (registration products are not bit-exact anyway: decision 0021); the numpy path
still runs where a restart has too few pairs (RelaxIfFew) and for point-to-point, and is what
tests/registration/test_kernels.py compares them with (the normal gate is compiled too since decision 0050).
Beside the step: the normals' scatter and closed-form axes, and the localizer's cloud kernels (the range test,
cube means, the bounded any-point test). Compiled once per machine and cached next to this file
(``cache=True``): the first registration on a fresh checkout compiles them, ~10-30 s of one core.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def pair_residuals(scene_body, distance, index, points, normals, spacing, truncation):  # pragma: no cover
    """Residuals (k, N) m of the point-to-plane step, as :func:`bim2rdt.registration.matching.plane_residual`:
    max(|n . (s - p)|, distance - spacing) of each scene point to its nearest sample, inf where unmatched; with
    each restart's pairs (k,) and truncated score (k,) m^2 (:func:`matching.truncated_score`)."""
    k, n = distance.shape
    residual = np.empty((k, n))
    pairs = np.zeros(k, np.int64)
    scores = np.zeros(k)
    for r in range(k):
        total = 0.0
        for i in range(n):
            d = distance[r, i]
            if not np.isfinite(d):
                residual[r, i] = np.inf
                total += truncation * truncation
                continue
            j = index[r, i]
            along = abs(normals[j, 0] * (scene_body[r, i, 0] - points[j, 0])
                        + normals[j, 1] * (scene_body[r, i, 1] - points[j, 1])
                        + normals[j, 2] * (scene_body[r, i, 2] - points[j, 2]))
            value = max(along, d - spacing)
            residual[r, i] = value
            pairs[r] += 1
            total += min(value, truncation) ** 2
        scores[r] = total / n
    return residual, pairs, scores


@njit(cache=True, nogil=True)
def gated_residuals(residual, index, T, normals_world, stride, model_normals, cos_gate):  # pragma: no cover
    """The pairs' residuals (k, N) for the step with the normal gate applied, as
    :func:`bim2rdt.registration.matching.gate_normals` gates them: a pair whose scene normal (``normals_world``,
    every ``stride``-th, turned into each restart's body frame by T (k, 4, 4)) and matched sample's normal are
    less than ``cos_gate`` apart in |cos| is no pair (its residual inf here; the score keeps the ungated
    residuals, as the numpy path's does). Returns the gated residuals and each restart's pair count (k,)."""
    k, n = residual.shape
    gated = residual.copy()
    pairs = np.zeros(k, np.int64)
    size = len(model_normals)
    for r in range(k):
        for i in range(n):
            if not np.isfinite(gated[r, i]):
                continue
            w0, w1, w2 = normals_world[i * stride, 0], normals_world[i * stride, 1], normals_world[i * stride, 2]
            b0 = w0 * T[r, 0, 0] + w1 * T[r, 1, 0] + w2 * T[r, 2, 0]
            b1 = w0 * T[r, 0, 1] + w1 * T[r, 1, 1] + w2 * T[r, 2, 1]
            b2 = w0 * T[r, 0, 2] + w1 * T[r, 1, 2] + w2 * T[r, 2, 2]
            s = min(index[r, i], size - 1)
            if abs(b0 * model_normals[s, 0] + b1 * model_normals[s, 1] + b2 * model_normals[s, 2]) >= cos_gate:
                pairs[r] += 1
            else:
                gated[r, i] = np.inf
    return gated, pairs


@njit(cache=True, nogil=True)
def _trim_cutoff(residual_row, trim_fraction, min_pairs, keep_within, buffer):  # pragma: no cover - compiled
    """The largest residual a pair of one restart may have after trimming (:func:`matching.trim_pairs`);
    ``buffer`` (N,) is scratch space."""
    count = 0
    for value in residual_row:
        if np.isfinite(value):
            buffer[count] = value
            count += 1
    if trim_fraction <= 0.0 or count == 0:
        return np.inf
    keep = max(math.ceil((1.0 - trim_fraction) * count), min(min_pairs, count))
    kept = buffer[:count]
    return max(np.partition(kept, keep - 1)[keep - 1], keep_within)


@njit(cache=True, nogil=True)
def normal_systems(scene_body, residual, index, points, normals, trim_fraction, min_pairs, keep_within, delta,
                   bias_gamma, up_body, g_dst, contact_src, contact_dst, contact_weight):  # pragma: no cover
    """The point-to-plane normal equations (A (k, 6, 6), b (k, 6)) of every restart, with the gravity term.

    Per restart: pairs with a finite residual (k, N) are trimmed (:func:`_trim_cutoff`), Huber-weighted at scale
    ``delta`` (m); lambda = bias_gamma (k,) x sum w |p - p_w|^2 (:func:`solvers.gravity_weight`); when
    ``contact_weight`` > 0 the resting-contact pair (``contact_src`` (k, 3) on the slab, ``contact_dst`` (k, 3)
    the lowest model point, normal ``up_body``) is added with weight ``contact_weight`` x the data's total
    weight. Then A = sum w J J^T and b = -sum w J r with r = n . (s - p), J = (s x n, n), plus the gravity
    residual sqrt(lambda)(R g_src - g_dst), g_src = ``up_body`` (k, 3), as in
    :func:`solvers.solve_point_to_plane`."""
    k, n = residual.shape
    A = np.zeros((k, 6, 6))
    b = np.zeros((k, 6))
    J = np.empty(6)
    A_r, b_r = np.empty((6, 6)), np.empty(6)  # one restart's sums, local (no aliasing with the outputs)
    weights, buffer = np.empty(n), np.empty(n)
    for r in range(k):
        cutoff = _trim_cutoff(residual[r], trim_fraction, min_pairs, keep_within, buffer)
        w_sum = 0.0
        c0 = c1 = c2 = 0.0
        for i in range(n):
            value = residual[r, i]
            w = 0.0
            if np.isfinite(value) and value <= cutoff:
                w = 1.0 if value <= delta else delta / max(value, 1e-12)
                w_sum += w
                j = index[r, i]
                c0 += w * points[j, 0]
                c1 += w * points[j, 1]
                c2 += w * points[j, 2]
            weights[i] = w
        total = max(w_sum, 1e-300)
        c0, c1, c2 = c0 / total, c1 / total, c2 / total
        A_r[:] = 0.0
        b_r[:] = 0.0
        spread = 0.0
        for i in range(n):
            w = weights[i]
            if w == 0.0:
                continue
            j = index[r, i]
            q0, q1, q2 = points[j, 0] - c0, points[j, 1] - c1, points[j, 2] - c2
            spread += w * (q0 * q0 + q1 * q1 + q2 * q2)
            _accumulate(A_r, b_r, J, w, scene_body[r, i, 0], scene_body[r, i, 1], scene_body[r, i, 2],
                        points[j, 0], points[j, 1], points[j, 2], normals[j, 0], normals[j, 1], normals[j, 2])
        if contact_weight > 0.0:
            _accumulate(A_r, b_r, J, contact_weight * w_sum, contact_src[r, 0], contact_src[r, 1],
                        contact_src[r, 2], contact_dst[r, 0], contact_dst[r, 1], contact_dst[r, 2],
                        up_body[r, 0], up_body[r, 1], up_body[r, 2])
        for a in range(6):
            b[r, a] = b_r[a]
            for c in range(a, 6):
                A[r, a, c] = A[r, c, a] = A_r[a, c]
        _add_gravity(A[r], b[r], bias_gamma[r] * spread, up_body[r], g_dst)
    return A, b


@njit(cache=True, nogil=True, inline="always")
def _accumulate(A, b, J, w, s0, s1, s2, p0, p1, p2, n0, n1, n2):  # pragma: no cover - compiled
    """Add one weighted point-to-plane pair (scene s, sample p, normal n) to A's upper triangle (6, 6) and b (6,)."""
    res = n0 * (s0 - p0) + n1 * (s1 - p1) + n2 * (s2 - p2)
    J[0], J[1], J[2] = s1 * n2 - s2 * n1, s2 * n0 - s0 * n2, s0 * n1 - s1 * n0
    J[3], J[4], J[5] = n0, n1, n2
    for a in range(6):
        wa = w * J[a]
        b[a] -= wa * res
        for c in range(a, 6):
            A[a, c] += wa * J[c]


@njit(cache=True, nogil=True)
def _add_gravity(A, b, lam, g_src, g_dst):  # pragma: no cover - compiled
    """A[:3, :3] += lam Jg^T Jg and b[:3] -= lam Jg^T (g_src - g_dst) with Jg = -[g_src]x."""
    g0, g1, g2 = g_src[0], g_src[1], g_src[2]
    Jg = np.array([[0.0, g2, -g1], [-g2, 0.0, g0], [g1, -g0, 0.0]])
    e = np.array([g0 - g_dst[0], g1 - g_dst[1], g2 - g_dst[2]])
    for a in range(3):
        for c in range(3):
            total = 0.0
            for m in range(3):
                total += Jg[m, a] * Jg[m, c]
            A[a, c] += lam * total
        total = 0.0
        for m in range(3):
            total += Jg[m, a] * e[m]
        b[a] -= lam * total


@njit(cache=True, nogil=True)
def solve_steps(A, b, degenerate_ratio):  # pragma: no cover - compiled
    """The full 6-DoF steps (dR (k, 3, 3), dt (k, 3)) of normal equations A (k, 6, 6), b (k, 6), as
    :func:`bim2rdt.registration.solvers.solve_system` (not yaw_only): rotation scaled by the lever arm, a
    direct (Cholesky) solve where A - tau I is positive definite (tau = ``degenerate_ratio`` x its trace),
    else only along the eigen-directions with at least ``degenerate_ratio`` of the largest eigenvalue."""
    k = len(A)
    dR = np.empty((k, 3, 3))
    dt = np.empty((k, 3))
    scales = np.ones(6)
    A_s = np.empty((6, 6))
    L = np.empty((6, 6))
    for r in range(k):
        rot = A[r, 0, 0] + A[r, 1, 1] + A[r, 2, 2]
        trans = A[r, 3, 3] + A[r, 4, 4] + A[r, 5, 5]
        lever = math.sqrt(rot / max(trans, 1e-300))
        for i in range(3):
            scales[i] = 1.0 / max(lever, 1e-6)
        trace = 0.0
        for i in range(6):
            for j in range(6):
                A_s[i, j] = scales[i] * A[r, i, j] * scales[j]
            trace += A_s[i, i]
        y = _scaled_solve(A_s, scales * b[r], trace, degenerate_ratio, L)
        x = scales * y
        _rodrigues(x[0], x[1], x[2], dR[r])
        dt[r, 0], dt[r, 1], dt[r, 2] = x[3], x[4], x[5]
    return dR, dt


@njit(cache=True, nogil=True)
def yaw_steps(A, b, g_src, degenerate_ratio):  # pragma: no cover - compiled
    """The yaw-only steps (dR (k, 3, 3), dt (k, 3)) of normal equations A (k, 6, 6), b (k, 6), as
    :func:`bim2rdt.registration.solvers.solve_system` with ``yaw_only``: the system projected onto the turn
    about each restart's ``g_src`` (k, 3, unit) and the three translations (4, 4), the turn scaled by the full
    system's lever arm, then solved as :func:`solve_steps` solves (Cholesky where A - tau I is positive
    definite, else along the eigen-directions with at least ``degenerate_ratio`` of the largest eigenvalue).
    The numpy solve's ~25 calls of a restart's step, one pass (decision 0050); LAPACK's LU solve there, a
    Cholesky here: the same step to round-off."""
    k = len(A)
    dR = np.empty((k, 3, 3))
    dt = np.empty((k, 3))
    A_s = np.empty((4, 4))
    L = np.empty((4, 4))
    rhs = np.empty(4)
    scales = np.ones(4)
    for r in range(k):
        g0, g1, g2 = g_src[r, 0], g_src[r, 1], g_src[r, 2]
        rot = A[r, 0, 0] + A[r, 1, 1] + A[r, 2, 2]
        trans = A[r, 3, 3] + A[r, 4, 4] + A[r, 5, 5]
        lever = math.sqrt(rot / max(trans, 1e-300))
        scales[0] = 1.0 / max(lever, 1e-6) if g0 * g0 + g1 * g1 + g2 * g2 > 0.0 else 1.0
        turn = 0.0
        for i in range(3):
            turn += g_src[r, i] * (A[r, i, 0] * g0 + A[r, i, 1] * g1 + A[r, i, 2] * g2)
        A_s[0, 0] = turn
        for m in range(3):
            across = g0 * A[r, 0, 3 + m] + g1 * A[r, 1, 3 + m] + g2 * A[r, 2, 3 + m]
            A_s[0, 1 + m] = across
            A_s[1 + m, 0] = across
            for n in range(3):
                A_s[1 + m, 1 + n] = A[r, 3 + m, 3 + n]
        rhs[0] = g0 * b[r, 0] + g1 * b[r, 1] + g2 * b[r, 2]
        for m in range(3):
            rhs[1 + m] = b[r, 3 + m]
        trace = 0.0
        for i in range(4):
            for j in range(4):
                A_s[i, j] = scales[i] * A_s[i, j] * scales[j]
            trace += A_s[i, i]
            rhs[i] = scales[i] * rhs[i]
        y = _scaled_solve(A_s, rhs, trace, degenerate_ratio, L)
        angle = scales[0] * y[0]
        _rodrigues(g0 * angle, g1 * angle, g2 * angle, dR[r])
        dt[r, 0], dt[r, 1], dt[r, 2] = y[1], y[2], y[3]
    return dR, dt


@njit(cache=True, nogil=True)
def _scaled_solve(A_s, rhs, trace, degenerate_ratio, L):  # pragma: no cover - compiled
    """y with A_s y = rhs for a scaled system (n, n) of the given trace: a direct (Cholesky) solve where A_s - tau I
    is positive definite (tau = ``degenerate_ratio`` x the trace), else only along the eigen-directions with at
    least ``degenerate_ratio`` of the largest eigenvalue. ``L`` (n, n) is scratch. Shared by :func:`solve_steps`
    and :func:`yaw_steps`."""
    n = len(rhs)
    tau = degenerate_ratio * trace
    if tau > 0.0 and _cholesky(A_s, tau, L):
        _cholesky(A_s, 0.0, L)
        return _cholesky_solve(L, rhs)
    values, vectors = np.linalg.eigh(A_s)
    top = max(values[n - 1], 1e-300)
    y = np.zeros(n)
    for m in range(n):
        if values[m] > degenerate_ratio * top:
            along = 0.0
            for i in range(n):
                along += vectors[i, m] * rhs[i]
            for i in range(n):
                y[i] += vectors[i, m] * along / values[m]
    return y


@njit(cache=True, nogil=True)
def _cholesky(A, shift, L):  # pragma: no cover - compiled
    """Cholesky factor of A - shift I (n, n) into L; False when it is not positive definite."""
    n = len(A)
    for i in range(n):
        for j in range(i + 1):
            total = A[i, j] - (shift if i == j else 0.0)
            for m in range(j):
                total -= L[i, m] * L[j, m]
            if i == j:
                if not total > 0.0:
                    return False
                L[i, i] = math.sqrt(total)
            else:
                L[i, j] = total / L[j, j]
    return True


@njit(cache=True, nogil=True)
def _cholesky_solve(L, rhs):  # pragma: no cover - compiled
    """x with L L^T x = rhs."""
    n = len(rhs)
    y = np.empty(n)
    for i in range(n):
        total = rhs[i]
        for m in range(i):
            total -= L[i, m] * y[m]
        y[i] = total / L[i, i]
    x = np.empty(n)
    for i in range(n - 1, -1, -1):
        total = y[i]
        for m in range(i + 1, n):
            total -= L[m, i] * x[m]
        x[i] = total / L[i, i]
    return x


@njit(cache=True, nogil=True)
def _rodrigues(w0, w1, w2, R):  # pragma: no cover - compiled
    """R (3, 3) = exp([w]x), as :func:`bim2rdt.registration.so3.exp_so3`."""
    theta = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    if theta < 1e-12:
        a, c = 1.0, 0.5
    else:
        a, c = math.sin(theta) / theta, (1.0 - math.cos(theta)) / theta**2
    K = np.array([[0.0, -w2, w1], [w2, 0.0, -w0], [-w1, w0, 0.0]])
    for i in range(3):
        for j in range(3):
            KK = K[i, 0] * K[0, j] + K[i, 1] * K[1, j] + K[i, 2] * K[2, j]
            R[i, j] = (1.0 if i == j else 0.0) + a * K[i, j] + c * KK


@njit(cache=True, nogil=True)
def body_points(T, scene, stride):  # pragma: no cover - compiled
    """Every ``stride``-th scene point (N, 3) in each pose's body frame: (k, n, 3) R^T (s - t) for poses T
    (k, 4, 4) model-to-world."""
    k = len(T)
    n = (len(scene) + stride - 1) // stride
    out = np.empty((k, n, 3))
    for r in range(k):
        for i in range(n):
            s = i * stride
            d0, d1, d2 = scene[s, 0] - T[r, 0, 3], scene[s, 1] - T[r, 1, 3], scene[s, 2] - T[r, 2, 3]
            for c in range(3):
                out[r, i, c] = T[r, 0, c] * d0 + T[r, 1, c] * d1 + T[r, 2, c] * d2
    return out


@njit(cache=True, nogil=True)
def compose_steps(T, dR, dt):  # pragma: no cover - compiled
    """The poses T (k, 4, 4) after their body-frame steps (dR (k, 3, 3), dt (k, 3)): T inv([dR, dt]), with
    each step's rotation angle (k,) rad (:func:`bim2rdt.registration.so3.rotation_angle`) and length (k,) m."""
    k = len(T)
    out = np.zeros((k, 4, 4))
    turned = np.empty(k)
    moved = np.empty(k)
    for r in range(k):
        back = np.empty(3)  # -dR^T dt
        for i in range(3):
            back[i] = -(dR[r, 0, i] * dt[r, 0] + dR[r, 1, i] * dt[r, 1] + dR[r, 2, i] * dt[r, 2])
        for i in range(3):
            for j in range(3):  # (T_R dR^T)_ij
                out[r, i, j] = T[r, i, 0] * dR[r, j, 0] + T[r, i, 1] * dR[r, j, 1] + T[r, i, 2] * dR[r, j, 2]
            out[r, i, 3] = T[r, i, 0] * back[0] + T[r, i, 1] * back[1] + T[r, i, 2] * back[2] + T[r, i, 3]
        out[r, 3, 3] = 1.0
        cos = (dR[r, 0, 0] + dR[r, 1, 1] + dR[r, 2, 2] - 1.0) / 2.0
        turned[r] = math.acos(min(max(cos, -1.0), 1.0))
        moved[r] = math.sqrt(dt[r, 0] ** 2 + dt[r, 1] ** 2 + dt[r, 2] ** 2)
    return out, turned, moved


@njit(cache=True, nogil=True)
def neighbour_scatter(points, index):  # pragma: no cover - compiled
    """Each point's neighbourhood scatter (n, 3, 3): with ``q_j = points[index[r, j]]`` (``index`` (n, k), the
    k nearest) and their mean m, sum_j (q_j - m)(q_j - m)^T. Bit for bit numpy's ``local = points[index] -
    points[index].mean(axis=1, keepdims=True)`` and ``einsum("nki,nkj->nij", local, local)``: the mean and each
    entry summed over j in order from 0, the mean divided by k (tests/registration/test_kernels.py compares
    them); where numpy's gather, mean and einsum made (n, k, 3) temporaries three times, ~15x faster on 6,000
    points x 12."""
    n, k = index.shape
    out = np.empty((n, 3, 3))
    local = np.empty((k, 3))
    for r in range(n):
        m0, m1, m2 = 0.0, 0.0, 0.0
        for j in range(k):
            p = index[r, j]
            m0 += points[p, 0]
            m1 += points[p, 1]
            m2 += points[p, 2]
        m0, m1, m2 = m0 / k, m1 / k, m2 / k
        for j in range(k):
            p = index[r, j]
            local[j, 0] = points[p, 0] - m0
            local[j, 1] = points[p, 1] - m1
            local[j, 2] = points[p, 2] - m2
        for a in range(3):
            for b in range(3):
                total = 0.0
                for j in range(k):
                    total += local[j, a] * local[j, b]
                out[r, a, b] = total
    return out


@njit(cache=True, nogil=True)
def smallest_axes(scatter):  # pragma: no cover - compiled
    """Eigenvalues (n, 3), ascending, and the unit eigenvector of the smallest (n, 3) of symmetric 3x3 matrices
    (n, 3, 3; the upper triangle is read), in closed form (Eberly, "A robust eigensolver for 3x3 symmetric
    matrices", 2014): the matrix scaled by its largest entry, the eigenvalues from the trigonometric solution of
    its characteristic cubic, the eigenvector of the one farthest from the other two by cross products of the
    rows of A - lambda I, the next in its orthogonal complement, the third their cross product. What
    ``np.linalg.eigh`` answers to round-off (~1e-15 relative to the largest eigenvalue; the vector's sign may
    differ), ~20x faster: a point's normal from its neighbours' scatter (:func:`neighbour_scatter`) needs only
    these. A zero matrix gives zeros and (1, 0, 0), as LAPACK does."""
    n = len(scatter)
    values = np.empty((n, 3))
    axes = np.empty((n, 3))
    for r in range(n):
        a00, a01, a02 = scatter[r, 0, 0], scatter[r, 0, 1], scatter[r, 0, 2]
        a11, a12, a22 = scatter[r, 1, 1], scatter[r, 1, 2], scatter[r, 2, 2]
        top = max(abs(a00), abs(a01), abs(a02), abs(a11), abs(a12), abs(a22))
        if top == 0.0:
            values[r, 0], values[r, 1], values[r, 2] = 0.0, 0.0, 0.0
            axes[r, 0], axes[r, 1], axes[r, 2] = 1.0, 0.0, 0.0
            continue
        a00, a01, a02, a11, a12, a22 = a00 / top, a01 / top, a02 / top, a11 / top, a12 / top, a22 / top
        off = a01 * a01 + a02 * a02 + a12 * a12
        if off == 0.0:  # diagonal: its entries, the smallest one's axis
            _sorted_diagonal(a00, a11, a22, top, values[r], axes[r])
            continue
        q = (a00 + a11 + a22) / 3.0
        b00, b11, b22 = a00 - q, a11 - q, a22 - q
        p = math.sqrt((b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * off) / 6.0)
        c00 = b11 * b22 - a12 * a12
        c01 = a01 * b22 - a12 * a02
        c02 = a01 * a12 - b11 * a02
        half_det = (b00 * c00 - a01 * c01 + a02 * c02) / (p * p * p) / 2.0
        half_det = min(max(half_det, -1.0), 1.0)
        angle = math.acos(half_det) / 3.0
        beta2 = 2.0 * math.cos(angle)
        beta0 = 2.0 * math.cos(angle + 2.0 * math.pi / 3.0)
        beta1 = -(beta0 + beta2)
        e0, e1, e2 = q + p * beta0, q + p * beta1, q + p * beta2
        values[r, 0], values[r, 1], values[r, 2] = e0 * top, e1 * top, e2 * top
        if half_det >= 0.0:  # the largest is the one set apart: its axis first, the smallest's last
            v2 = _axis_of(a00, a01, a02, a11, a12, a22, e2)
            v1 = _axis_in_complement(a00, a01, a02, a11, a12, a22, v2, e1)
            axes[r, 0] = v1[1] * v2[2] - v1[2] * v2[1]
            axes[r, 1] = v1[2] * v2[0] - v1[0] * v2[2]
            axes[r, 2] = v1[0] * v2[1] - v1[1] * v2[0]
        else:
            v0 = _axis_of(a00, a01, a02, a11, a12, a22, e0)
            axes[r, 0], axes[r, 1], axes[r, 2] = v0[0], v0[1], v0[2]
    return values, axes


@njit(cache=True, nogil=True)
def _sorted_diagonal(d0, d1, d2, scale, values, axis):  # pragma: no cover - compiled
    """A diagonal matrix's eigenvalues ascending (times ``scale``) into ``values`` and its smallest's axis."""
    smallest = 0
    if d1 < d0 and d1 <= d2:
        smallest = 1
    elif d2 < d0 and d2 < d1:
        smallest = 2
    middle = max(min(d0, d1), min(max(d0, d1), d2))
    values[0], values[1], values[2] = min(d0, d1, d2) * scale, middle * scale, max(d0, d1, d2) * scale
    axis[0], axis[1], axis[2] = 0.0, 0.0, 0.0
    axis[smallest] = 1.0


@njit(cache=True, nogil=True)
def _axis_of(a00, a01, a02, a11, a12, a22, value):  # pragma: no cover - compiled
    """The unit eigenvector of a simple eigenvalue ``value``: the longest cross product of two rows of A -
    value I (each is orthogonal to both rows, so along the null space)."""
    r00, r11, r22 = a00 - value, a11 - value, a22 - value
    x0 = (a01 * a12 - a02 * r11, a02 * a01 - r00 * a12, r00 * r11 - a01 * a01)
    x1 = (a01 * r22 - a02 * a12, a02 * a02 - r00 * r22, r00 * a12 - a01 * a02)
    x2 = (r11 * r22 - a12 * a12, a12 * a02 - a01 * r22, a01 * a12 - r11 * a02)
    d0 = x0[0] * x0[0] + x0[1] * x0[1] + x0[2] * x0[2]
    d1 = x1[0] * x1[0] + x1[1] * x1[1] + x1[2] * x1[2]
    d2 = x2[0] * x2[0] + x2[1] * x2[1] + x2[2] * x2[2]
    if d0 >= d1 and d0 >= d2:
        best, length = x0, math.sqrt(d0)
    elif d1 >= d2:
        best, length = x1, math.sqrt(d1)
    else:
        best, length = x2, math.sqrt(d2)
    return (best[0] / length, best[1] / length, best[2] / length)


@njit(cache=True, nogil=True)
def _axis_in_complement(a00, a01, a02, a11, a12, a22, w, value):  # pragma: no cover - compiled
    """The unit eigenvector of ``value`` orthogonal to the unit eigenvector ``w``: the 2x2 problem on the plane
    orthogonal to ``w`` (basis u, v), its null direction taken from the larger row (robust when ``value`` is
    double)."""
    if abs(w[0]) > abs(w[1]):
        inv = 1.0 / math.sqrt(w[0] * w[0] + w[2] * w[2])
        u0, u1, u2 = -w[2] * inv, 0.0, w[0] * inv
    else:
        inv = 1.0 / math.sqrt(w[1] * w[1] + w[2] * w[2])
        u0, u1, u2 = 0.0, w[2] * inv, -w[1] * inv
    v0, v1, v2 = w[1] * u2 - w[2] * u1, w[2] * u0 - w[0] * u2, w[0] * u1 - w[1] * u0
    au0 = a00 * u0 + a01 * u1 + a02 * u2
    au1 = a01 * u0 + a11 * u1 + a12 * u2
    au2 = a02 * u0 + a12 * u1 + a22 * u2
    av0 = a00 * v0 + a01 * v1 + a02 * v2
    av1 = a01 * v0 + a11 * v1 + a12 * v2
    av2 = a02 * v0 + a12 * v1 + a22 * v2
    m00 = u0 * au0 + u1 * au1 + u2 * au2 - value
    m01 = u0 * av0 + u1 * av1 + u2 * av2
    m11 = v0 * av0 + v1 * av1 + v2 * av2 - value
    if abs(m00) >= abs(m11):
        if max(abs(m00), abs(m01)) == 0.0:
            return (u0, u1, u2)
        p, q = _unit_pair(m00, m01)  # the null direction of M is q u - p v
        return (q * u0 - p * v0, q * u1 - p * v1, q * u2 - p * v2)
    if max(abs(m11), abs(m01)) == 0.0:
        return (u0, u1, u2)
    p, q = _unit_pair(m11, m01)  # the null direction of M is p u - q v
    return (p * u0 - q * v0, p * u1 - q * v1, p * u2 - q * v2)


@njit(cache=True, nogil=True, inline="always")
def _unit_pair(p, q):  # pragma: no cover - compiled
    """(p, q) scaled to unit length (up to sign), dividing by the larger of the two first (Eberly's robust
    normalisation: no overflow, no square of a tiny number)."""
    if abs(p) >= abs(q):
        q /= p
        p = 1.0 / math.sqrt(1.0 + q * q)
        q *= p
    else:
        p /= q
        q = 1.0 / math.sqrt(1.0 + p * p)
        p *= q
    return p, q


@njit(cache=True, nogil=True)
def in_range(points, low, high):  # pragma: no cover - compiled
    """(N,) bool: rows of ``points`` (N, 3) whose every coordinate is finite and whose length lies in [``low``,
    ``high``]: numpy's ``np.all(np.isfinite(points), axis=1)`` and then ``np.linalg.norm(points, axis=1)``, the
    same squares summed x, y, z in order (so the same lengths bit for bit), in one pass without temporaries."""
    n = len(points)
    keep = np.empty(n, np.bool_)
    for i in range(n):
        x, y, z = points[i, 0], points[i, 1], points[i, 2]
        if not (np.isfinite(x) and np.isfinite(y) and np.isfinite(z)):
            keep[i] = False
            continue
        length = math.sqrt(x * x + y * y + z * z)
        keep[i] = low <= length <= high
    return keep


@njit(cache=True, nogil=True)
def cube_means(points, voxel, dense_cubes):  # pragma: no cover - compiled
    """One mean point per occupied cube of side ``voxel`` (M, 3), cubes in ascending key order (x, then y,
    then z, from the points' least cube), each cube's points summed in their own order from 0: what
    :func:`bim2rdt.localization.cloud.voxel_means` computes with ``np.floor``, a count table and ``np.bincount``,
    bit for bit, in three passes. A box of more than ``dense_cubes`` cubes gives None (the caller sorts)."""
    n = len(points)
    cells = np.empty((n, 3), np.int64)
    for i in range(n):
        for c in range(3):
            cells[i, c] = np.int64(math.floor(points[i, c] / voxel))
    low = np.empty(3, np.int64)
    size = np.empty(3, np.int64)
    for c in range(3):
        low[c] = cells[:, c].min()
        size[c] = cells[:, c].max() - low[c] + 1
    if float(size[0]) * float(size[1]) * float(size[2]) > dense_cubes:
        return None
    count = np.zeros(size[0] * size[1] * size[2], np.int64)
    key = np.empty(n, np.int64)
    for i in range(n):
        key[i] = ((cells[i, 0] - low[0]) * size[1] + (cells[i, 1] - low[1])) * size[2] + (cells[i, 2] - low[2])
        count[key[i]] += 1
    rank = np.empty(len(count), np.int64)
    occupied = 0
    for c in range(len(count)):
        if count[c]:
            rank[c] = occupied
            occupied += 1
    sums = np.zeros((occupied, 3))
    counts = np.zeros(occupied, np.int64)
    for i in range(n):
        r = rank[key[i]]
        sums[r, 0] += points[i, 0]
        sums[r, 1] += points[i, 1]
        sums[r, 2] += points[i, 2]
        counts[r] += 1
    for r in range(occupied):
        for c in range(3):
            sums[r, c] = sums[r, c] / counts[r]
    return sums


@njit(cache=True, nogil=True, error_model="numpy")  # a ray along its face's plane: inf or NaN, as numpy's
def hit_depths(face, face_normals, vertices, faces, origin, directions):  # pragma: no cover - compiled
    """Ray parameters t (N,) of rays ``origin`` + t ``directions`` (N, 3) at the plane of the triangle each first
    hit (``face`` (N,), -1 none: t NaN), and that triangle's unit normal (N, 3; zeros for none): t = n . (v0 -
    origin) / n . d with v0 the triangle's first corner, each dot's three products summed (x + z) + y, as
    numpy's ``einsum("ni,ni->n")`` sums them here (tests/registration/test_kernels.py), in one pass where
    numpy's masked gathers and scatters of a frame's 127,000 rays cost ~10 ms."""
    n = len(face)
    t = np.full(n, np.nan)
    normals = np.zeros((n, 3))
    for i in range(n):
        f = face[i]
        if f < 0:
            continue
        n0, n1, n2 = face_normals[f, 0], face_normals[f, 1], face_normals[f, 2]
        v = faces[f, 0]
        near = n0 * (vertices[v, 0] - origin[0]) + n2 * (vertices[v, 2] - origin[2])
        near += n1 * (vertices[v, 1] - origin[1])
        along = n0 * directions[i, 0] + n2 * directions[i, 2]
        along += n1 * directions[i, 1]
        t[i] = near / along
        normals[i, 0], normals[i, 1], normals[i, 2] = n0, n1, n2
    return t, normals


@njit(cache=True, nogil=True)
def any_within(points, queries, radius, bound):  # pragma: no cover - compiled
    """(Q,) bool: whether any of ``points`` (P, 3) lies nearer than ``radius`` to each of ``queries`` (Q, 3): a
    grid of cubes a hair wider than ``radius`` over the points' box, each query tested against the points of the
    27 cubes around its own. The test is pykdtree's bounded query's, operation for operation (the squared distance
    summed x, y, z from 0 as ``(query - point)`` squared, a hit below ``bound``, Python's ``radius * radius``), so
    the answer is ``np.isfinite(SampleTree(points).query(queries, distance_upper_bound=radius)[0])`` bit for bit."""
    found = np.zeros(len(queries), np.bool_)
    if len(points) == 0 or not radius > 0.0:
        return found
    cube = radius * (1.0 + 1e-6)  # a point nearer than radius lies at most one cube away on each axis
    lo = np.empty(3)
    span = np.empty(3, np.int64)
    for c in range(3):
        lo[c] = points[:, c].min()
        span[c] = int(math.floor((points[:, c].max() - lo[c]) / cube)) + 1
    cubes = span[0] * span[1] * span[2]
    key = np.empty(len(points), np.int64)
    for i in range(len(points)):
        ix = int(math.floor((points[i, 0] - lo[0]) / cube))
        iy = int(math.floor((points[i, 1] - lo[1]) / cube))
        iz = int(math.floor((points[i, 2] - lo[2]) / cube))
        key[i] = (min(ix, span[0] - 1) * span[1] + min(iy, span[1] - 1)) * span[2] + min(iz, span[2] - 1)
    order = np.argsort(key, kind="mergesort")
    start = np.zeros(cubes + 1, np.int64)
    for i in range(len(points)):
        start[key[i] + 1] += 1
    for k in range(cubes):
        start[k + 1] += start[k]
    for q in range(len(queries)):
        x, y, z = queries[q, 0], queries[q, 1], queries[q, 2]
        cx = int(math.floor((x - lo[0]) / cube))
        cy = int(math.floor((y - lo[1]) / cube))
        cz = int(math.floor((z - lo[2]) / cube))
        if cx < -1 or cy < -1 or cz < -1 or cx > span[0] or cy > span[1] or cz > span[2]:
            continue
        hit = False
        for ix in range(max(cx - 1, 0), min(cx + 2, span[0])):
            for iy in range(max(cy - 1, 0), min(cy + 2, span[1])):
                for iz in range(max(cz - 1, 0), min(cz + 2, span[2])):
                    k = (ix * span[1] + iy) * span[2] + iz
                    for j in range(start[k], start[k + 1]):
                        p = order[j]
                        d0 = x - points[p, 0]
                        d1 = y - points[p, 1]
                        d2 = z - points[p, 2]
                        distance = 0.0
                        distance += d0 * d0
                        distance += d1 * d1
                        distance += d2 * d2
                        if distance < bound:
                            hit = True
                            break
                    if hit:
                        break
                if hit:
                    break
            if hit:
                break
        found[q] = hit
    return found


@njit(cache=True, nogil=True)
def plane_steps(T, scene_body, residual, index, points, normals, hull, trim_fraction, min_pairs, keep_within,
                delta, bias_gamma, up_world, g_dst, support_height, support_weight,
                degenerate_ratio, yaw_only):  # pragma: no cover - compiled
    """The point-to-plane steps (dR (k, 3, 3), dt (k, 3)) of restarts at poses T (k, 4, 4) in one call: each
    restart's world up in its body frame (R^T ``up_world``), its resting contact when ``support_height`` (m along
    ``up_world``) is finite (the lowest of the ``hull`` points along that up, dropped onto the slab, as
    :func:`bim2rdt.registration.icp._contact`), then :func:`normal_systems` and :func:`solve_steps`, or
    :func:`yaw_steps` with ``yaw_only`` (decisions 0045, 0050: the ~10 numpy calls between them were a tenth of
    an iteration, the yaw-only solve's ~25 a quarter)."""
    k = len(T)
    up_body = np.empty((k, 3))
    contact = np.zeros((k, 3))
    on_slab = np.zeros((k, 3))
    for r in range(k):
        for i in range(3):
            up_body[r, i] = T[r, 0, i] * up_world[0] + T[r, 1, i] * up_world[1] + T[r, 2, i] * up_world[2]
    weight = 0.0
    if np.isfinite(support_height):
        weight = support_weight
        for r in range(k):
            lowest, height = 0, np.inf
            for h in range(len(hull)):
                value = hull[h, 0] * up_body[r, 0] + hull[h, 1] * up_body[r, 1] + hull[h, 2] * up_body[r, 2]
                if value < height:
                    lowest, height = h, value
            slab = support_height - (T[r, 0, 3] * up_world[0] + T[r, 1, 3] * up_world[1] + T[r, 2, 3] * up_world[2])
            gap = (up_body[r, 0] * hull[lowest, 0] + up_body[r, 1] * hull[lowest, 1]
                   + up_body[r, 2] * hull[lowest, 2]) - slab
            for i in range(3):
                contact[r, i] = hull[lowest, i]
                on_slab[r, i] = hull[lowest, i] - gap * up_body[r, i]
    A, b = normal_systems(scene_body, residual, index, points, normals, trim_fraction, min_pairs, keep_within, delta,
                          bias_gamma, up_body, g_dst, on_slab, contact, weight)
    if yaw_only:
        return yaw_steps(A, b, up_body, degenerate_ratio)
    return solve_steps(A, b, degenerate_ratio)


@njit(cache=True, nogil=True)
def settle_steps(poses, iterations, scores, done, active, dR, dt, new_scores, rot_rad, trans, score_rel,
                 annealing):  # pragma: no cover - compiled
    """Apply the body-frame steps (dR (k, 3, 3), dt (k, 3)) of the ``active`` restarts (k,) to their poses
    (K, 4, 4), in place, as :func:`compose_steps`; count their iterations, record their scores and, unless
    ``annealing``, mark done (K,) those whose step turned less than ``rot_rad`` and moved less than ``trans``
    (m), or whose score changed by at most ``score_rel`` of it (:func:`bim2rdt.registration.icp._advance`)."""
    composed, turned, moved = compose_steps(poses[active], dR, dt)
    for m in range(len(active)):
        r = active[m]
        poses[r] = composed[m]
        iterations[r] += 1
        previous = scores[r]
        scores[r] = new_scores[m]
        small = turned[m] < rot_rad and moved[m] < trans
        stalled = abs(previous - new_scores[m]) <= score_rel * new_scores[m]
        if not annealing and (small or stalled):
            done[r] = True


@njit(cache=True, nogil=True)
def count_near(poses, keep, pose, centroid, distance, degrees):  # pragma: no cover - compiled
    """How many of ``poses`` (K, 4, 4) with ``keep`` (K,) put the model's ``centroid`` (body frame) within
    ``distance`` (m) of where ``pose`` (4, 4) puts it and are turned by less than ``degrees`` from it, as
    :func:`bim2rdt.registration.icp.near`."""
    limit = np.deg2rad(degrees)
    count = 0
    for r in range(len(poses)):
        if not keep[r]:
            continue
        shift = 0.0
        for i in range(3):
            along = (poses[r, i, 3] - pose[i, 3]
                     + (poses[r, i, 0] - pose[i, 0]) * centroid[0] + (poses[r, i, 1] - pose[i, 1]) * centroid[1]
                     + (poses[r, i, 2] - pose[i, 2]) * centroid[2])
            shift += along * along
        trace = 0.0
        for i in range(3):
            trace += poses[r, i, 0] * pose[i, 0] + poses[r, i, 1] * pose[i, 1] + poses[r, i, 2] * pose[i, 2]
        turn = math.acos(min(max((trace - 1.0) / 2.0, -1.0), 1.0))
        if math.sqrt(shift) < distance and turn < limit:
            count += 1
    return count


@njit(cache=True, nogil=True)
def stop_agreed(poses, scores, done, pruned, start, stop, centroid, agreed, margin):  # pragma: no cover
    """:func:`bim2rdt.registration.icp.stop_if_agreed` on restarts ``start``..``stop`` (in place on ``pruned``):
    drop the running ones once ``agreed`` converged restarts ended within 1 cm and 1 degree of the
    lowest-scoring one, itself converged, and every running one scores worse than ``margin`` x its score."""
    best, lowest, running = -1, np.inf, 0
    for r in range(start, stop):
        if pruned[r]:
            continue
        if not done[r]:
            running += 1
        if scores[r] < lowest or best < 0:
            best, lowest = r, scores[r]
    if running == 0 or not done[best]:
        return
    settled = np.zeros(stop - start, np.bool_)
    for r in range(start, stop):
        settled[r - start] = done[r] and not pruned[r]
    if count_near(poses[start:stop], settled, poses[best], centroid, 0.01, 1.0) < agreed:
        return
    for r in range(start, stop):
        if not done[r] and not pruned[r] and not scores[r] > margin * lowest:
            return
    for r in range(start, stop):
        if not done[r] and not pruned[r]:
            pruned[r] = True


@njit(cache=True, nogil=True)
def warm_nearest(scene_body, nearest, active, stride, points, near_ids, near_radius, low, high,
                 bound):  # pragma: no cover - compiled
    """The exact nearest samples of scene points in restarts' body frames (``scene_body`` (k, n, 3), every
    ``stride``-th scene point of the ``active`` restarts) where the answer can be proved, as the k-d tree would
    give them: (distance (k, n) m, inf beyond ``bound``; index (k, n), ``len(points)`` for a miss; the flat
    indices of the points it could not prove, for the tree).

    A point at least ``bound`` from the samples' bounding box (``low``, ``high``) is a miss. Otherwise, with s
    the point's last nearest sample in ``nearest`` (K, N) (-1: none; then the previous scene point's, a pixel
    next to it) and d' the point's distance to it, the true nearest s* is within d' of the point, so within
    2 d' of s: when 2 d' is below ``near_radius[s]`` (every sample nearer s is listed in ``near_ids[s]``), s*
    is the nearest of s's neighbours. A point far from its last sample (a restart that moved, a first
    iteration) is left to the tree."""
    k, n, _ = scene_body.shape
    distance = np.full((k, n), np.inf)
    index = np.full((k, n), len(points), np.int64)
    cold = np.empty(k * n, np.int64)
    count = 0
    limit = bound * bound
    for m in range(k):
        row = active[m]
        for i in range(n):
            p0, p1, p2 = scene_body[m, i, 0], scene_body[m, i, 1], scene_body[m, i, 2]
            out0 = max(low[0] - p0, p0 - high[0], 0.0)
            out1 = max(low[1] - p1, p1 - high[1], 0.0)
            out2 = max(low[2] - p2, p2 - high[2], 0.0)
            if out0 * out0 + out1 * out1 + out2 * out2 > limit * (1.0 + 1e-9) + 1e-18:
                continue  # no sample within the bound: a miss
            s = nearest[row, i * stride]
            if s < 0 and i > 0:
                s = nearest[row, (i - 1) * stride]
            proved = False
            if s >= 0:
                d0, d1, d2 = p0 - points[s, 0], p1 - points[s, 1], p2 - points[s, 2]
                reach = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                if 2.0 * reach * (1.0 + 1e-9) + 1e-12 < near_radius[s]:
                    proved = True
                    best, best_sq = -1, np.inf
                    for c in range(near_ids.shape[1]):
                        j = near_ids[s, c]
                        e0, e1, e2 = p0 - points[j, 0], p1 - points[j, 1], p2 - points[j, 2]
                        sq = e0 * e0 + e1 * e1 + e2 * e2
                        if sq < best_sq:
                            best, best_sq = j, sq
                    if best_sq < limit:
                        distance[m, i] = math.sqrt(best_sq)
                        index[m, i] = best
            if not proved:
                cold[count] = m * n + i
                count += 1
    return distance, index, cold[:count]


@njit(cache=True, nogil=True)
def remember_nearest(nearest, active, stride, index, size):  # pragma: no cover - compiled
    """Record the nearest samples ``index`` (k, n) of the ``active`` restarts' every ``stride``-th scene point in
    ``nearest`` (K, N), where one was found (an index below ``size``, the sample count)."""
    k, n = index.shape
    for m in range(k):
        row = active[m]
        for i in range(n):
            if index[m, i] < size:
                nearest[row, i * stride] = index[m, i]


@njit(cache=True, nogil=True)
def nearest_patches(points, distance, index, samples, normals, radius, cos_edge, cos_other,
                    tie):  # pragma: no cover - compiled
    """Where points (N, 3) lie on the model surface, from their nearest candidate samples ``index`` (N, c)
    ``distance`` (N, c) m away (inf = none), as :func:`bim2rdt.registration.matching.nearest_patches_of`
    computes it with numpy (``surfel_distances``, ``exact.first_smallest``): the distance (N,) m to the
    nearest sample patch (discs of ``radius`` m cut where the surface turns away convexly, normals more than
    acos(``cos_edge``) apart), that patch's sample (N,), and the distance (N,) m to the nearest patch whose
    normal is more than acos(``cos_other``) from its (inf if none). Among patches within ``tie`` m of the
    nearest, the first candidate."""
    n, c = distance.shape
    size = len(samples)
    out_distance = np.empty(n)
    out_sample = np.empty(n, np.int64)
    out_other = np.empty(n)
    height = np.empty(c)
    to_patch = np.empty(c)
    cand = np.empty(c, np.int64)
    for r in range(n):
        for j in range(c):
            cand[j] = min(index[r, j], size - 1)
            s = cand[j]
            o0, o1, o2 = points[r, 0] - samples[s, 0], points[r, 1] - samples[s, 1], points[r, 2] - samples[s, 2]
            height[j] = o0 * normals[s, 0] + o1 * normals[s, 1] + o2 * normals[s, 2]
        for j in range(c):
            if not np.isfinite(distance[r, j]):
                to_patch[j] = np.inf
                continue
            s = cand[j]
            o0, o1, o2 = points[r, 0] - samples[s, 0], points[r, 1] - samples[s, 1], points[r, 2] - samples[s, 2]
            tangential = math.sqrt(max(o0 * o0 + o1 * o1 + o2 * o2 - height[j] ** 2, 0.0))
            clip = -np.inf
            for m in range(c):
                if not np.isfinite(distance[r, m]):
                    continue
                t = cand[m]
                cos = normals[s, 0] * normals[t, 0] + normals[s, 1] * normals[t, 1] + normals[s, 2] * normals[t, 2]
                behind = (samples[s, 0] * normals[t, 0] + samples[s, 1] * normals[t, 1] + samples[s, 2] * normals[t, 2]
                          - (normals[t, 0] * samples[t, 0] + normals[t, 1] * samples[t, 1]
                             + normals[t, 2] * samples[t, 2]))
                if cos < cos_edge and behind < 0.0:
                    sin = math.sqrt(max(1.0 - cos * cos, 1e-12))
                    clip = max(clip, (height[m] - height[j] * cos) / sin)
            excess = max(max(tangential - radius, clip), 0.0)
            to_patch[j] = math.hypot(height[j], excess)
        lowest = np.inf
        for j in range(c):
            lowest = min(lowest, to_patch[j])
        nearest = 0
        for j in range(c):
            if to_patch[j] <= lowest + tie:
                nearest = j
                break
        s = cand[nearest]
        other = np.inf
        for j in range(c):
            t = cand[j]
            cos = normals[t, 0] * normals[s, 0] + normals[t, 1] * normals[s, 1] + normals[t, 2] * normals[s, 2]
            if cos < cos_other:
                other = min(other, to_patch[j])
        out_distance[r], out_sample[r], out_other[r] = to_patch[nearest], s, other
    return out_distance, out_sample, out_other
