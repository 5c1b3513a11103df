"""bim2rdt.exact: small products computed term by term (the same bits on any machine), and ties by position."""

from __future__ import annotations

import numpy as np

from bim2rdt import exact


def test_products_equal_numpys_to_rounding_and_the_explicit_left_to_right_sum_bit_for_bit():
    rng = np.random.default_rng(0)
    points, R, T = rng.normal(size=(500, 3)), rng.normal(size=(3, 3)), np.eye(4)
    T[:3, :3], T[:3, 3] = R, (1.0, -2.0, 0.5)
    by_hand = points[:, 0:1] * R[:, 0] + points[:, 1:2] * R[:, 1] + points[:, 2:3] * R[:, 2]
    assert np.array_equal(exact.rotate(R, points), by_hand)
    assert np.allclose(exact.rotate(R, points), points @ R.T, rtol=0, atol=1e-14)
    assert np.allclose(exact.transform(T, points), points @ R.T + T[:3, 3], rtol=0, atol=1e-14)
    assert np.allclose(exact.matmul(R, points[0]), R @ points[0], rtol=0, atol=1e-14)
    assert np.allclose(exact.matmul(points[0], R), points[0] @ R, rtol=0, atol=1e-14)
    stacked = rng.normal(size=(4, 3, 3))
    assert np.allclose(exact.matmul(stacked, stacked), stacked @ stacked, rtol=0, atol=1e-13)
    assert exact.matmul(points[0], points[1]) == points[0, 0] * points[1, 0] + points[0, 1] * points[1, 1] \
        + points[0, 2] * points[1, 2]
    assert np.allclose(exact.norm(points), np.linalg.norm(points, axis=1), rtol=1e-15)


def test_the_inverse_of_a_rigid_pose_undoes_it():
    T = np.eye(4)
    T[:3, :3] = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    T[:3, 3] = (2.0, 3.0, 4.0)
    assert np.allclose(exact.inverse_pose(T) @ T, np.eye(4), rtol=0, atol=1e-15)


def test_near_ties_go_to_the_first_and_clear_minima_to_the_smallest():
    values = np.array([[0.3, 0.1 + 1e-15, 0.1, 0.2], [0.5, 0.4, 0.1, 0.1]])
    assert exact.first_smallest(values, axis=1).tolist() == [1, 2]  # argmin says [2, 2]
    assert exact.first_smallest(np.array([3.0, 1.0, 2.0])) == 1
