"""Planar camera states: a pose splits into (x, y, z, yaw) and the IMU's tilt, and odometry increments compose."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.localization.planar import between, compose, from_planar, heading, to_planar
from bim2rdt.perception import look_at


def test_a_pose_splits_into_state_and_tilt_and_back():
    T = look_at((3.0, 4.0, 1.1), (6.0, 8.0, 0.3))
    state, tilt = to_planar(T)
    assert state[:3] == pytest.approx([3.0, 4.0, 1.1])
    assert state[3] == pytest.approx(np.arctan2(4.0, 3.0))
    assert from_planar(state, tilt) == pytest.approx(T)
    assert heading(from_planar(state + [0, 0, 0, 0.3], tilt)) == pytest.approx(state[3] + 0.3)


def test_an_increment_moves_in_the_heading_frame_and_between_inverts_compose():
    start = np.array([1.0, 2.0, 0.5, np.pi / 2])
    moved = compose(start, np.array([1.0, 0.5, 0.1, 0.2]))
    assert moved == pytest.approx([1.0 - 0.5, 2.0 + 1.0, 0.6, np.pi / 2 + 0.2])
    assert between(start, moved) == pytest.approx([1.0, 0.5, 0.1, 0.2])


def test_yaw_wraps_across_pi():
    state = compose(np.array([0.0, 0.0, 0.0, 3.0]), np.array([0.0, 0.0, 0.0, 0.5]))
    assert state[3] == pytest.approx(3.5 - 2 * np.pi)
    assert between(np.array([0.0, 0.0, 0.0, 3.0]), state)[3] == pytest.approx(0.5)
