"""Line of sight is exact on the grid, and smoothing keeps a path's corners only where it must turn."""

from __future__ import annotations

import numpy as np

from bim2rdt.planning.smoothing import in_sight, smooth, turning_points


def test_a_segment_clipping_the_corner_of_a_blocked_cell_is_not_in_sight():
    blocked = np.zeros((10, 10), bool)
    blocked[5, 5] = True
    assert not in_sight(blocked, np.array([4.5, 0.5]), np.array([5.9, 9.5]))   # clips cell (5, 5) near a corner
    assert in_sight(blocked, np.array([4.5, 0.5]), np.array([4.99, 9.5]))       # stays in row 4
    assert in_sight(blocked, np.array([4.0, 4.0]), np.array([6.0, 6.0]) - 1e-12) is False
    assert in_sight(blocked, np.array([4.5, 5.5]), np.array([5.5, 4.5]))        # touches (5, 5) at a corner only
    assert not in_sight(blocked, np.array([4.5, 6.5]), np.array([6.5, 4.5]))    # through its centre
    blocked[5, 5], blocked[4, 4] = False, True
    assert not in_sight(blocked, np.array([4.5, 6.5]), np.array([4.5, 0.5]))


def test_turning_points_keep_the_ends_and_every_change_of_direction():
    cells = np.array([[0, 0], [0, 1], [0, 2], [1, 3], [2, 4], [2, 5]])
    assert turning_points(cells).tolist() == [[0, 0], [0, 2], [2, 4], [2, 5]]


def test_a_staircase_in_an_open_room_smooths_to_one_straight_leg():
    blocked = np.zeros((50, 50), bool)
    cells = np.array([[i // 2, i - i // 2] for i in range(60)])
    corners = smooth(cells, blocked, cells[0] + 0.5, cells[-1] + 0.5)
    assert len(corners) == 2


def test_smoothing_goes_round_an_obstacle_not_through_it():
    blocked = np.zeros((30, 30), bool)
    blocked[5:25, 14:16] = True
    cells = np.array([[r, 2] for r in range(2, 3)] + [[3, c] for c in range(3, 17)] + [[r, 17] for r in range(4, 28)])
    corners = smooth(cells, blocked, np.array([2.5, 2.5]), np.array([27.5, 17.5]))
    assert all(in_sight(blocked, a, b) for a, b in zip(corners[:-1], corners[1:]))
    assert len(corners) >= 3


def test_line_of_sight_agrees_with_dense_sampling_on_random_segments():
    rng = np.random.default_rng(3)
    blocked = rng.random((60, 60)) < 0.02
    for _ in range(300):
        a, b = rng.uniform(0.0, 60.0, 2), rng.uniform(0.0, 60.0, 2)
        if rng.random() < 0.3:
            b = a + rng.uniform(-3.0, 3.0, 2)
            b = np.clip(b, 0.0, 59.999)
        t = np.linspace(0.0, 1.0, 20000)[:, None]
        cells = np.floor(a + t * (b - a)).astype(int)
        assert in_sight(blocked, a, b) == (not blocked[cells[:, 0], cells[:, 1]].any()), (a, b)
