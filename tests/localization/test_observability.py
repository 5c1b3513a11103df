"""Observability of point-to-plane pairs: what a view constrains, what it leaves free, and the covariance."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.localization.observability import lever_arm, observability, pair_information

YAW_ONLY = np.zeros((6, 4))
YAW_ONLY[:3, :3], YAW_ONLY[5, 3] = np.eye(3), 1.0


def _plane(origin, u, v, normal, n=400, seed=0):
    """Points on a rectangle origin + [0,1]u + [0,1]v with the given normal."""
    rng = np.random.default_rng(seed)
    a, b = rng.random((2, n))
    points = np.asarray(origin) + a[:, None] * np.asarray(u) + b[:, None] * np.asarray(v)
    return points, np.tile(np.asarray(normal, dtype=float), (n, 1))


def _stack(*planes):
    return np.vstack([p for p, _ in planes]), np.vstack([n for _, n in planes])


def _of(points, normals, centre=np.zeros(3), basis=YAW_ONLY):
    info = pair_information(points, normals, centre) / 0.01**2
    return observability(info, lever_arm(points, centre), 0.1, basis, 100.0)


def test_the_information_of_one_pair_is_its_jacobian_squared():
    p, n, c = np.array([[2.0, 1.0, 0.5]]), np.array([[0.0, -1.0, 0.0]]), np.array([1.0, 0.0, 0.0])
    J = np.r_[n[0], np.cross(p[0] - c, n[0])]
    assert pair_information(p, n, c) == pytest.approx(np.outer(J, J))


def test_a_wall_and_the_floor_leave_the_position_along_the_wall_free_and_nothing_else():
    seen = _of(*_stack(_plane((-3, 3, 0), (6, 0, 0), (0, 0, 3), (0, -1, 0)),
                       _plane((-3, 0.5, 0), (6, 0, 0), (0, 2.5, 0), (0, 0, 1))))
    assert len(seen.degenerate_translations) == 1
    assert abs(seen.degenerate_translations[0] @ [1, 0, 0]) == pytest.approx(1.0)
    assert seen.degenerate_rotations == []
    assert seen.covariance[0, 0] == pytest.approx(100.0**2, rel=1e-6)
    assert seen.covariance[1, 1] < 1e-6 and seen.covariance[5, 5] < 1e-6
    assert seen.information[0] == pytest.approx(np.zeros(6), abs=1e-9)


def test_two_walls_and_the_floor_constrain_every_direction():
    seen = _of(*_stack(_plane((-3, 3, 0), (6, 0, 0), (0, 0, 3), (0, -1, 0)),
                       _plane((-3, -1, 0), (0, 4, 0), (0, 0, 3), (1, 0, 0)),
                       _plane((-3, -1, 0), (6, 0, 0), (0, 4, 0), (0, 0, 1))))
    assert seen.degenerate_translations == [] and seen.degenerate_rotations == []
    assert np.all(np.diag(seen.covariance)[[0, 1, 2, 5]] < 1e-6)


def test_a_bare_floor_leaves_x_y_and_yaw_free():
    seen = _of(*_plane((-3, 0.5, 0), (6, 0, 0), (0, 4, 0), (0, 0, 1)))
    free = np.array(seen.degenerate_translations)
    assert len(free) == 2 and np.allclose(np.abs(free @ [0, 0, 1]), 0.0)
    assert len(seen.degenerate_rotations) == 1 and abs(seen.degenerate_rotations[0] @ [0, 0, 1]) == pytest.approx(1)


def test_the_covariance_is_the_inverse_information_where_everything_is_constrained():
    points, normals = _stack(*[_plane((-2, -2, 0), (4, 0, 0), (0, 4, 0), (0, 0, 1), seed=1),
                               _plane((-2, 2, 0), (4, 0, 0), (0, 0, 3), (0, -1, 0), seed=2),
                               _plane((-2, -2, 0), (0, 4, 0), (0, 0, 3), (1, 0, 0), seed=3),
                               _plane((2, -2, 0), (0, 4, 0), (0, 0, 3), (-1, 0, 0), seed=4)])
    centre = np.array([0.0, 0.0, 1.0])
    info = pair_information(points, normals, centre)
    seen = observability(info, lever_arm(points, centre))
    assert seen.covariance == pytest.approx(np.linalg.inv(info), rel=1e-6)


def test_a_weak_coupling_of_a_free_shift_to_yaw_does_not_spread_it_into_yaw():
    """A wall leaves x free; three poor points on a column side (1 m noise) couple x weakly to yaw. x stays free
    (as a pure shift), yaw is not reported free, and its variance is not inflated by x's."""
    wall = _plane((-3, 3, 0), (6, 0, 0), (0, 0, 3), (0, -1, 0))
    floor = _plane((-3, 0.5, 0), (6, 0, 0), (0, 2.5, 0), (0, 0, 1))
    side = _plane((1.0, 2.0, 0), (0, 0.3, 0), (0, 0, 0.5), (-1, 0, 0), n=3)
    points, normals = _stack(wall, floor)
    info = pair_information(points, normals, np.zeros(3)) / 0.01**2 + pair_information(*side, np.zeros(3)) / 1.0**2
    seen = observability(info, lever_arm(points, np.zeros(3)), 0.1, YAW_ONLY, 100.0)
    assert len(seen.degenerate_translations) == 1 and abs(seen.degenerate_translations[0][0]) == pytest.approx(1.0)
    assert seen.degenerate_rotations == []
    assert np.sqrt(seen.covariance[5, 5]) < 1e-3


def test_a_direction_pinned_looser_than_max_sigma_is_free_and_tighter_is_constrained():
    wall, floor = _plane((-3, 3, 0), (6, 0, 0), (0, 0, 3), (0, -1, 0)), _plane((-3, 0.5, 0), (6, 0, 0), (0, 2.5, 0), (0, 0, 1))
    side = _plane((1.0, 2.0, 0), (0, 0.3, 0), (0, 0, 0.5), (-1, 0, 0), n=1)
    points, normals = _stack(wall, floor)
    base = pair_information(points, normals, np.zeros(3)) / 0.01**2
    for sigma, free in ((0.2, 1), (0.05, 0)):  # one point on the side pins x to about its own sigma
        info = base + pair_information(*side, np.zeros(3)) / sigma**2
        assert len(observability(info, lever_arm(points, np.zeros(3)), 0.1, YAW_ONLY).degenerate_translations) == free
