"""The world frame every package shares: z-up, metres (docs/concepts/frames-and-units.md).

``UP`` is the world's up axis; ``UP_BODY`` a body frame's own up (a family's model, built upright along +z). They are
the same vector in two frames, so the registration's upright prior and the perception's fits pull a body's up
(``R_world_body @ UP_BODY``) onto ``UP``. Every package takes them from here."""

from __future__ import annotations

import numpy as np

UP = np.array([0.0, 0.0, 1.0])
"""The world's up axis (z), a unit (3,) vector. Read it, never write into it."""
UP.flags.writeable = False

UP_BODY = UP
"""A body's (a family model's) up axis in body coordinates: +z, the same read-only (3,) vector as :data:`UP`; the
name says the frame."""

RIGID_TOLERANCE = 1e-3
"""The largest entry of ``R @ R.T - I`` a rotation block may show and still count as a rotation: a matrix typed
by hand with three decimals (0.707 for cos 45 deg) is 3e-4 off, while a scale or shear of 0.1 % is refused. One
value for every check (decision 0036), so a pose one reader accepts no later stage refuses."""


def rigid_problem(T: object) -> str | None:
    """Why ``T`` is not a rigid 4x4 pose (rotation and translation), or None when it is.

    Every pose check of bim2rdt calls this one rule (decision 0036): finite numbers in a 4x4; a rotation block
    orthonormal within :data:`RIGID_TOLERANCE` with determinant +1 (no mirror); a last row of exactly 0 0 0 1
    (within 1e-9: a homogeneous row, not a projection).

    Args:
        T: The candidate pose, anything numpy reads as an array.

    Returns:
        None for a rigid pose, else a short phrase ("not a 4x4 matrix (shape (3, 3))", "its last row is not
            0 0 0 1", ...) for the caller to put in its own error.
    """
    try:
        T = np.asarray(T, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        return "not a 4x4 matrix of numbers"
    if T.shape != (4, 4):
        return f"not a 4x4 matrix (shape {T.shape})"
    if not np.all(np.isfinite(T)):
        return "it holds NaN or infinite values"
    if np.abs(T[3] - (0.0, 0.0, 0.0, 1.0)).max() > 1e-9:
        return "its last row is not 0 0 0 1"
    R = T[:3, :3]
    if np.abs(R @ R.T - np.eye(3)).max() > RIGID_TOLERANCE:
        return f"its 3x3 block is not a rotation (scale or shear beyond {RIGID_TOLERANCE:g})"
    if np.linalg.det(R) < 0:
        return "its 3x3 block is a mirror (determinant -1), not a rotation"
    return None
