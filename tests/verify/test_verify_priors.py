"""A prior from a position, a heading and an IMU's up: roll and pitch from up, the heading kept."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.perception import look_at
from bim2rdt.verify import VerifyError, heading_deg, levelled, prior_pose


def test_a_level_prior_looks_along_its_heading_with_the_image_upright():
    T = prior_pose((1.0, 2.0, 1.5), 90.0)
    assert np.allclose(T[:3, 2], (0, 1, 0), atol=1e-12)  # optical axis along +y
    assert np.allclose(T[:3, 1], (0, 0, -1), atol=1e-12)  # image down is world down
    assert np.allclose(T[:3, 3], (1.0, 2.0, 1.5))


def test_up_measured_in_a_tilted_sensor_gives_back_its_roll_and_pitch():
    truth = look_at((0.0, 0.0, 1.4), (3.0, 1.0, 0.2))  # looking 21 degrees down
    roll = np.eye(4)
    c, s = np.cos(0.05), np.sin(0.05)
    roll[:2, :2] = [[c, -s], [s, c]]  # and rolled about its optical axis
    truth = truth @ roll
    up_sensor = truth[:3, :3].T @ (0, 0, 1)  # what an IMU in the sensor would read
    T = prior_pose(truth[:3, 3], heading_deg(truth), up_sensor)
    assert np.allclose(T, truth, atol=1e-9)
    assert np.allclose(levelled(prior_pose(truth[:3, 3], heading_deg(truth)), up_sensor), truth, atol=1e-9)


@pytest.mark.parametrize("up, message", [((0, 0, 0), "non-zero"), ((0, 0, 1), "optical axis")])
def test_an_up_that_gives_no_attitude_is_refused(up, message):
    with pytest.raises(VerifyError, match=message):
        prior_pose((0, 0, 0), 0.0, up)
