"""The depth correction p_true = p / (1 - g . p): on points, and on a depth image along each pixel's ray."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.perception import Intrinsics
from bim2rdt.sources import correct_depth, correct_points

G = np.array([0.060504, 0.007131, -0.004063])


def test_corrected_points_follow_the_formula_point_by_point():
    points = np.array([[-2.0, 0.5, 5.1], [0.0, 0.0, 2.0], [1.0, 1.2, 3.0]])
    expected = np.array([p / (1.0 - G @ p) for p in points])
    assert np.allclose(correct_points(points, G), expected, atol=1e-12)


def test_a_corrected_depth_image_gives_the_corrected_points_on_the_same_rays():
    intrinsics = Intrinsics(64, 48, 52.5, 52.5, 32.0, 24.0)
    rng = np.random.default_rng(3)
    depth = rng.uniform(0.5, 5.0, (48, 64)).astype(np.float32)
    depth[5, 7], depth[6, 8] = 0.0, np.nan
    points = intrinsics.pixel_rays() * depth[..., None].astype(np.float64)
    expected = np.array([p / (1.0 - G @ p) for p in points.reshape(-1, 3)]).reshape(48, 64, 3)
    corrected = correct_depth(depth, intrinsics, G)
    ok = depth > 0
    assert np.allclose(corrected[ok], expected[..., 2][ok], rtol=1e-6)
    assert corrected[5, 7] == 0.0 and np.isnan(corrected[6, 8])


def test_a_point_with_no_true_position_becomes_no_return():
    far_right = np.array([[20.0, 0.0, 10.0]])  # g . p = 1.21: beyond infinity after the correction
    assert np.isnan(correct_points(far_right, G)).all()
    intrinsics = Intrinsics(2, 1, 1.0, 1.0, -1.0, 0.0)  # rays x/z = 1 and 2: g . p = 2 and 4
    assert np.isnan(correct_depth(np.array([[20.0, 20.0]]), intrinsics, (0.1, 0.0, 0.0))).all()


def test_a_correction_that_is_not_three_numbers_is_refused():
    with pytest.raises(ValueError, match="three"):
        correct_points(np.zeros((1, 3)), (0.1, 0.2))
