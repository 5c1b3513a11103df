"""Poses modulo an object's rotational symmetry about its body z (up) axis.

A drum turned about its own axis, a square-based cone turned by 90 degrees or an I-beam by 180 degrees shows
the same surface: judging such a pose against a reference (the BIM's, or the truth) must first turn it by the
symmetry that brings it closest. The order ``n`` is the number of turns in 360 degrees that map the body onto
itself: 1 = none, 2 = a half turn (a pallet), 4 = a quarter turn (a square plate), ``math.inf`` = any (a drum)."""

from __future__ import annotations

import math

import numpy as np

from bim2rdt.frames import UP_BODY
from bim2rdt.registration.so3 import axis_angle


def closest_equivalent(T: np.ndarray, T_ref: np.ndarray, order: float) -> np.ndarray:
    """The pose (4x4, model to world) that shows the same object as ``T`` (turned about its body z axis by a
    symmetry of order ``order``) and is closest in rotation to ``T_ref``. Metrics on fixed surface samples then
    measure the surface error, not the sampling: a drum turned by 10 degrees about its axis puts every sample
    somewhere else, on the same surface.

    Args:
        T: (4, 4) the pose to turn, model to world, metres.
        T_ref: (4, 4) the reference pose, model to world, metres.
        order: The symmetry's order about body z: 1 (none), 2, 4, ... or ``math.inf`` (any turn).

    Returns:
        (4, 4) ``T`` turned about its body z axis by the symmetry that brings its rotation closest to
            ``T_ref``'s; its translation unchanged.
    """
    M = T_ref[:3, :3].T @ T[:3, :3]
    if math.isinf(order):  # argmax over theta of tr(M Rz(theta))
        angles = np.array([np.arctan2(M[0, 1] - M[1, 0], M[0, 0] + M[1, 1])])
    else:
        angles = 2 * np.pi * np.arange(int(order)) / int(order)
    turns = axis_angle(np.tile(UP_BODY, (len(angles), 1)), angles)
    best = turns[int(np.argmax(np.trace(M @ turns, axis1=1, axis2=2)))]
    out = T.copy()
    out[:3, :3] = T[:3, :3] @ best
    return out
