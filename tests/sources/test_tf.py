"""The TF buffer's quaternion arithmetic, against scipy's: a quaternion to a matrix, and interpolation between
two samples on the shorter arc (what tf2 does), including a sample pair on opposite hemispheres."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from bim2rdt.sources.tf import TfBuffer, matrix, slerp


def test_a_quaternion_gives_scipys_rotation_matrix_and_the_translation():
    q = Rotation.from_euler("xyz", [10.0, -35.0, 120.0], degrees=True).as_quat()
    T = matrix((1.0, 2.0, 3.0), 2.0 * q)  # not unit: normalised
    assert np.allclose(T[:3, :3], Rotation.from_quat(q).as_matrix()) and np.allclose(T[:3, 3], (1.0, 2.0, 3.0))
    assert np.allclose(T[3], (0.0, 0.0, 0.0, 1.0))


@pytest.mark.parametrize("s", [0.0, 0.25, 0.5, 0.9, 1.0])
@pytest.mark.parametrize("flip", [False, True])
def test_slerp_matches_scipys_on_the_shorter_arc(s, flip):
    q0 = Rotation.from_euler("z", 10.0, degrees=True).as_quat()
    q1 = Rotation.from_euler("zy", [70.0, 20.0], degrees=True).as_quat() * (-1.0 if flip else 1.0)
    expected = Slerp([0.0, 1.0], Rotation.from_quat([q0, q1]))([s])[0].as_matrix()
    assert np.allclose(Rotation.from_quat(slerp(q0, q1, s)).as_matrix(), expected, atol=1e-9)


def test_a_lookup_between_two_samples_interpolates_translation_and_rotation():
    buffer = TfBuffer(tolerance=0.02, max_gap=2.0)
    buffer.add("odom", "base_link", (0.0, 0.0, 0.0), Rotation.from_euler("z", 0.0, degrees=True).as_quat(), 1.0)
    buffer.add("odom", "base_link", (2.0, 0.0, 0.0), Rotation.from_euler("z", 90.0, degrees=True).as_quat(), 2.0)
    T = buffer.lookup("odom", "base_link", 1.25)
    assert np.allclose(T[:3, 3], (0.5, 0.0, 0.0))
    assert np.isclose(Rotation.from_matrix(T[:3, :3]).as_euler("xyz", degrees=True)[2], 22.5)
