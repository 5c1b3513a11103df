"""pose_deviation: translation, tilt and yaw of a measured pose against the BIM's, modulo the family's symmetry."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bim2rdt.twin import pose_deviation


def _pose(x=0.0, y=0.0, z=0.0, yaw=0.0, tilt=0.0, base_yaw=0.0):
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("zxz", [base_yaw, tilt, yaw], degrees=True).as_matrix()
    T[:3, 3] = (x, y, z)
    return T


def test_a_pure_shift_is_translation_only():
    d = pose_deviation(_pose(1, 2, 0, yaw=30), _pose(1.03, 2.04, 0, yaw=30))
    assert d.translation == pytest.approx(0.05)
    assert d.tilt_deg == pytest.approx(0.0, abs=1e-9) and d.yaw_deg == pytest.approx(0.0, abs=1e-9)


def test_yaw_is_measured_about_the_bim_up_axis_with_its_sign():
    d = pose_deviation(_pose(yaw=30), _pose(yaw=30 + 12.5))
    assert d.yaw_deg == pytest.approx(12.5) and d.tilt_deg == pytest.approx(0.0, abs=1e-9)
    assert pose_deviation(_pose(yaw=30), _pose(yaw=30 - 7)).yaw_deg == pytest.approx(-7.0)


def test_tilt_is_the_angle_between_up_axes_whatever_the_yaw():
    d = pose_deviation(_pose(base_yaw=40), _pose(base_yaw=40, tilt=8, yaw=0))
    assert d.tilt_deg == pytest.approx(8.0)
    assert abs(d.yaw_deg) < 1e-6


@pytest.mark.parametrize("symmetry, turn, expected", [(4, 90.0, 0.0), (4, 95.0, 5.0), (4, 44.0, 44.0),
                                                      (4, 46.0, -44.0), (2, 181.0, 1.0), (1, 181.0, -179.0),
                                                      (math.inf, 73.0, 0.0)])
def test_yaw_is_taken_modulo_the_family_symmetry(symmetry, turn, expected):
    d = pose_deviation(_pose(yaw=10), _pose(yaw=10 + turn), symmetry)
    assert d.yaw_deg == pytest.approx(expected, abs=1e-9)


def test_within_checks_all_three_against_the_tolerance():
    d = pose_deviation(_pose(), _pose(0.04, 0, 0, yaw=4.9))
    assert d.within(0.05, 5.0)
    assert not d.within(0.03, 5.0) and not d.within(0.05, 4.0)
    assert not pose_deviation(_pose(), _pose(tilt=5.5)).within(0.05, 5.0)
