"""The EKF over (x, y, z, yaw): odometry grows the uncertainty, a fix shrinks it only where it constrains."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.localization import Localization, OdometryNoise, PoseFilter, fuse_frame
from bim2rdt.localization.planar import from_planar, to_planar
from bim2rdt.perception import look_at
from loc_helpers import frame, offset


def _fix(state, information_diag):
    """A fix at ``state`` (x, y, z, yaw) with a diagonal information over (x, y, z, ., ., yaw)."""
    information = np.diag(np.r_[information_diag[:3], 0.0, 0.0, information_diag[3]])
    covariance = np.diag(np.where(information.diagonal() > 0, 1.0 / np.maximum(information.diagonal(), 1e-300), 1e4))
    pose = from_planar(np.asarray(state, float), np.eye(3))
    free = [np.eye(3)[k] for k in range(3) if information_diag[k] == 0]
    return Localization(pose, covariance, 1000, free, 0.005, information_diag[3] == 0, information, 1000, 1000,
                        0.0, 0.0, pose)


def test_odometry_grows_the_uncertainty_with_distance_and_heading_turns_the_shift():
    f = PoseFilter(np.zeros(4), np.diag([1e-6, 1e-6, 1e-6, 1e-6]))
    f.predict(np.array([10.0, 0.0, 0.0, 0.0]))
    assert f.state == pytest.approx([10.0, 0.0, 0.0, 0.0])
    assert np.sqrt(f.covariance[0, 0]) == pytest.approx(0.2, rel=0.01)  # 2 % of 10 m
    assert np.sqrt(f.covariance[3, 3]) == pytest.approx(np.deg2rad(1.0), rel=0.01)  # 1 deg per 10 m
    f.predict(np.array([5.0, 0.0, 0.0, 0.0]))
    sideways = 0.2**2 + 0.1**2 + (5.0 * np.deg2rad(1.0)) ** 2  # both legs drift, and the heading spreads the second
    assert f.covariance[1, 1] == pytest.approx(sideways, rel=0.02)


def test_a_full_fix_pulls_the_state_to_itself():
    f = PoseFilter(np.array([10.0, 0.2, 1.1, 0.02]), np.diag([0.04, 0.04, 1e-4, 3e-4]))
    correction = f.update(_fix([10.1, 0.0, 1.1, 0.0], [1e6, 1e6, 1e6, 1e7]))
    assert f.state == pytest.approx([10.1, 0.0, 1.1, 0.0], abs=1e-3)
    assert correction == pytest.approx([0.1, -0.2, 0.0, -0.02], abs=1e-3)
    assert np.all(np.diag(f.covariance) < 1e-5)


def test_a_degenerate_fix_corrects_only_what_it_constrains():
    f = PoseFilter(np.array([10.0, 0.2, 1.1, 0.02]), np.diag([0.04, 0.04, 1e-4, 3e-4]))
    f.update(_fix([9.0, 0.0, 1.1, 0.0], [0.0, 1e6, 1e6, 1e7]))  # blind along x: its x of 9.0 means nothing
    assert f.state[0] == pytest.approx(10.0)
    assert f.covariance[0, 0] == pytest.approx(0.04)
    assert f.state[1:] == pytest.approx([0.0, 1.1, 0.0], abs=1e-3)


def test_a_fix_far_beyond_the_odometrys_drift_is_gated():
    f = PoseFilter(np.array([10.0, 0.0, 1.1, 0.0]), np.diag([0.01, 0.01, 1e-4, 1e-4]))
    near, far = _fix([10.15, 0.0, 1.1, 0.0], [1e6] * 4), _fix([11.5, 0.0, 1.1, 0.0], [1e6] * 4)
    assert f.surprise(near)[0] < f.surprise(near)[1] < f.surprise(far)[0]


def test_fuse_frame_fixes_a_drifted_estimate_and_keeps_the_odometry_when_the_frame_is_refused(site_model, built):
    truth = look_at((8.5, 2.0, 1.1), (11.85, 6.5, 0.8))
    state, tilt = to_planar(offset(truth, 0.15, -0.1, 1.5))
    f = PoseFilter(state, np.diag([0.04, 0.04, 1e-4, np.deg2rad(2.0) ** 2]), OdometryNoise())
    station = fuse_frame(f, frame(built, truth), site_model, tilt)
    assert station.applied and station.fix is not None
    assert np.linalg.norm(f.state[:3] - truth[:3, 3]) < 0.01
    outward = look_at((10.0, -4.0, 1.1), (10.0, -10.0, 0.5))  # outside, facing the open ground
    f.state, tilt = to_planar(outward)
    before = f.state.copy()
    refused = fuse_frame(f, frame(built, outward), site_model, tilt)
    assert not refused.applied and refused.fix is None and "no permanent element" in refused.reason
    assert f.state == pytest.approx(before) and refused.correction == pytest.approx(np.zeros(4))
