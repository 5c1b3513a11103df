"""The paper's Hausdorff statistics."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.registration import RegistrationError, hausdorff


def test_hausdorff_of_a_shifted_copy_pools_both_directions():
    a = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    b = np.array([[0.0, 0.0, 0.1], [1.0, 0.0, 0.1], [3.0, 0.0, 0.0]])
    stats = hausdorff(a, b)
    distances = np.array([0.1, 0.1, 0.1, 0.1, 2.0])
    assert stats.max == pytest.approx(2.0)
    assert stats.mean == pytest.approx(distances.mean())
    assert stats.rmse == pytest.approx(np.sqrt(np.mean(distances**2)))


def test_identical_sets_have_zero_distance():
    a = np.random.default_rng(0).normal(size=(50, 3))
    assert hausdorff(a, a.copy()).max == 0.0


@pytest.mark.parametrize("points_a, points_b, message", [
    (np.zeros((3, 3)), np.zeros((0, 3)), r"points_b must have shape \(N, 3\) with N >= 1, got \(0, 3\)"),
    (np.zeros((3, 2)), np.zeros((3, 3)), r"points_a must have shape \(N, 3\) with N >= 1, got \(3, 2\)"),
    (np.zeros(3), np.zeros((3, 3)), r"points_a must have shape"),
    (np.zeros((3, 3)), [[0.0, np.nan, 0.0]], "points_b contains NaN or infinite values"),
    ([[np.inf, 0.0, 0.0]], np.zeros((3, 3)), "points_a contains NaN or infinite values"),
])
def test_bad_point_sets_raise_a_registration_error_naming_the_set(points_a, points_b, message):
    with pytest.raises(RegistrationError, match=message):
        hausdorff(points_a, points_b)
