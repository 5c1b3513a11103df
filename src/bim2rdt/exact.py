"""Small products whose every bit is the same on any machine (docs/decisions/0021).

``points @ R.T`` hands an (N, 3) x (3, 3) product to BLAS, whose kernel (chosen for the CPU at run time: with
or without fused multiply-add, SIMD width) rounds differently in the last bit; so do ``np.linalg.norm`` of a
vector (a BLAS dot) and ``np.linalg.inv``. Here each output element is an explicit left-to-right sum of
element-wise products (numpy's element-wise multiply and add are correctly rounded IEEE operations and are never
fused), so the result is bit-identical across CPUs, BLAS kernels and thread counts. Meant for short inner
dimensions (3, 4): the cost is one array pass per term.
"""

from __future__ import annotations

import numpy as np


def matmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` for a (..., n, k) and b (..., k, m), or a vector (k,) on either side, bit-exact."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if a.ndim == 1 and b.ndim == 1:
        return dot_rows(a, b)
    if b.ndim == 1:
        return _terms(a, b[None, :], axis=-1)
    if a.ndim == 1:
        return matmul(a[None, :], b)[..., 0, :]
    total = a[..., :, 0:1] * b[..., 0:1, :]
    for j in range(1, a.shape[-1]):
        total = total + a[..., :, j:j + 1] * b[..., j:j + 1, :]
    return total


def dot_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot products of a and b (..., k) -> (...), bit-exact (``einsum("ni,ni->n")``)."""
    return _terms(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64), axis=-1)


def norm(v: np.ndarray) -> np.ndarray:
    """Euclidean length of vectors (..., k) -> (...), bit-exact."""
    return np.sqrt(dot_rows(v, v))


def rotate(R: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Points (N, 3) turned by R (3, 3): ``points @ R.T``, bit-exact."""
    return matmul(points, np.asarray(R).T)


def transform(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Points (N, 3) mapped by the 4x4 pose T: ``points @ T[:3, :3].T + T[:3, 3]``, bit-exact."""
    return rotate(T[:3, :3], points) + T[:3, 3]


def inverse_pose(T: np.ndarray) -> np.ndarray:
    """The inverse of a rigid 4x4 pose (R^T, -R^T t), bit-exact (``np.linalg.inv`` is LAPACK)."""
    R_t = np.asarray(T[:3, :3], dtype=np.float64).T
    out = np.eye(4)
    out[:3, :3] = R_t
    out[:3, 3] = -matmul(R_t, T[:3, 3])
    return out


def _terms(a: np.ndarray, b: np.ndarray, axis: int) -> np.ndarray:
    total = np.take(a, 0, axis=axis) * np.take(b, 0, axis=axis)
    for j in range(1, a.shape[axis]):
        total = total + np.take(a, j, axis=axis) * np.take(b, j, axis=axis)
    return total


TIE_TOLERANCE = 1e-9
"""Values closer than this (metres, or the unit at hand) are a tie for :func:`first_smallest`."""


def first_smallest(values: np.ndarray, axis: int = 0, tolerance: float = TIE_TOLERANCE) -> np.ndarray:
    """Index of the smallest of ``values`` along ``axis``, the first one among those within ``tolerance`` of it:
    ``np.argmin`` picks among near-equal values (points on one flat base) by their last bits, which differ
    between machines; this picks by position, which does not."""
    values = np.asarray(values)
    near = values <= np.min(values, axis=axis, keepdims=True) + tolerance
    return np.argmax(near, axis=axis)
