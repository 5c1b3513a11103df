"""Helpers of the localization tests: render a frame, make a prior that is off, measure pose errors."""

from __future__ import annotations

import numpy as np

from bim2rdt.localization.planar import from_planar, to_planar
from bim2rdt.sim.tour import render_frame


def frame(scene, T_world_camera, seed=0):
    return render_frame(scene.scene, T_world_camera, np.random.default_rng(seed))


def offset(T_world_camera, dx=0.0, dy=0.0, dyaw_deg=0.0):
    """The pose moved by (dx, dy) m and turned by dyaw about world z: an odometry prior that is off."""
    state, tilt = to_planar(T_world_camera)
    return from_planar(state + np.array([dx, dy, 0.0, np.deg2rad(dyaw_deg)]), tilt)


def errors(T_est, T_true):
    """(position error vector (3,) m, yaw error deg)."""
    a, _ = to_planar(T_est)
    b, _ = to_planar(T_true)
    yaw = (np.rad2deg(a[3] - b[3]) + 180.0) % 360.0 - 180.0
    return T_est[:3, 3] - T_true[:3, 3], yaw
