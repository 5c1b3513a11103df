"""The plan search's compiled count gives the full scan's answer: the same pose and count, ties broken alike, every
candidate's count equal to a k-d tree query's (pykdtree's, through SampleTree, and scipy's), at the bound too."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from bim2rdt.registration import SampleTree
from bim2rdt.verify.shift_search import Located, best_shift


def full_scan(local, start, yaws_deg, steps, points, support):
    """Every turn and shift scored with scipy's cKDTree; the first of the highest counts kept."""
    tree = cKDTree(points)
    shifts = np.array([(x, y) for x in steps for y in steps])
    best, best_count = start, -1
    for yaw in yaws_deg:
        c, s = np.cos(np.deg2rad(yaw)), np.sin(np.deg2rad(yaw))
        turn = np.eye(4)
        turn[:2, :2] = [[c, -s], [s, c]]
        pose = start @ turn
        placed = local @ pose[:3, :3].T + pose[:3, 3]
        moved = placed[None, :, :] + np.c_[shifts, np.zeros(len(shifts))][:, None, :]
        gap, _ = tree.query(moved.reshape(-1, 3), distance_upper_bound=support)
        counts = np.isfinite(gap).reshape(len(shifts), len(local)).sum(axis=1)
        k = int(np.argmax(counts))
        if counts[k] > best_count:
            best_count, best = int(counts[k]), pose.copy()
            best[:2, 3] += shifts[k]
    return best, best_count / len(local)


def scene(seed: int, offset=(0.23, -0.11)):
    """A box's front face sampled (body frame) and a noisy copy of it moved by ``offset``, with clutter."""
    rng = np.random.default_rng(seed)
    face = np.c_[rng.uniform(-0.4, 0.4, 300), np.full(300, -0.3), rng.uniform(0.0, 0.8, 300)]
    start = np.eye(4)
    start[:3, 3] = [2.0, 1.0, 0.0]
    seen = face + start[:3, 3] + [*offset, 0.0] + rng.normal(0, 0.01, face.shape)
    clutter = rng.uniform([1.0, 0.0, 0.0], [3.0, 2.0, 1.0], (400, 3))
    return face, start, np.concatenate([seen[::2], clutter])


@pytest.mark.parametrize("seed", range(6))
def test_coarse_and_fine_scans_match_the_full_scan(seed):
    face, start, points = scene(seed)
    coarse = np.arange(-0.5, 0.5 + 1e-9, 0.05)
    fine = np.arange(-0.04, 0.04 + 1e-9, 0.01)
    for yaws, steps in (([0.0], coarse), ([-6.0, -3.0, 0.0, 3.0, 6.0], fine)):
        pose, share = best_shift(face, start, yaws, steps, Located(points), 0.04)
        want_pose, want_share = full_scan(face, start, yaws, steps, points, 0.04)
        assert np.array_equal(pose, want_pose)
        assert share == want_share
    found, _ = best_shift(face, start, [0.0], coarse, Located(points), 0.04)
    assert np.allclose(found[:2, 3], start[:2, 3] + [0.25, -0.1])  # the grid's nearest to the true offset


def test_ties_keep_the_first_in_scan_order():
    """Points on a grid a whole number of shifts wide: many shifts cover equally; the first one wins."""
    face = np.array([[0.0, 0.0, 0.0]])
    points = np.array([[x, y, 0.0] for x in (-0.2, 0.0, 0.2) for y in (-0.2, 0.0, 0.2)])
    steps = np.arange(-0.3, 0.3 + 1e-9, 0.05)
    pose, share = best_shift(face, np.eye(4), [0.0, 5.0], steps, Located(points), 0.04)
    want_pose, want_share = full_scan(face, np.eye(4), [0.0, 5.0], steps, points, 0.04)
    assert np.array_equal(pose, want_pose) and share == want_share == 1.0
    assert np.allclose(pose[:2, 3], [-0.2, -0.2])


def test_nothing_located_keeps_the_start():
    face, start, _ = scene(0)
    far = np.array([[50.0, 50.0, 50.0]])
    pose, share = best_shift(face, start, [0.0], np.arange(-0.5, 0.5 + 1e-9, 0.05), Located(far), 0.04)
    want_pose, want_share = full_scan(face, start, [0.0], np.arange(-0.5, 0.5 + 1e-9, 0.05), far, 0.04)
    assert np.array_equal(pose, want_pose) and share == want_share == 0.0


def test_a_later_shift_near_more_points_does_not_win_a_tie():
    """Shift (0.1, 0) covers as many samples as (0, 0) and lies near more points (one 5 cm from its second
    sample): the earlier (0, 0) is kept, as the full scan keeps it."""
    face = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    points = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [1.15, 0.0, 0.0]])
    steps = np.array([0.0, 0.05, 0.1])
    pose, share = best_shift(face, np.eye(4), [0.0], steps, Located(points), 0.04)
    want_pose, want_share = full_scan(face, np.eye(4), [0.0], steps, points, 0.04)
    assert np.array_equal(pose, want_pose) and share == want_share == 0.5
    assert np.allclose(pose[:2, 3], [0.0, 0.0])


def test_uneven_and_unsorted_steps_match_the_full_scan():
    """Uneven steps, and steps that do not ascend (every shift then tested for every point near in height)."""
    face, start, points = scene(3)
    for steps in (np.array([-0.3, -0.1, 0.0, 0.05, 0.25]), np.array([0.25, -0.3, 0.05, 0.0, -0.1])):
        pose, share = best_shift(face, start, [0.0, 4.0], steps, Located(points), 0.04)
        want_pose, want_share = full_scan(face, start, [0.0, 4.0], steps, points, 0.04)
        assert np.array_equal(pose, want_pose) and share == want_share


def tree_counts(placed, steps, points, support):
    """Every candidate's count with pykdtree's query (SampleTree), turn-major, shifts x-major."""
    shifts = np.array([(x, y) for x in steps for y in steps])
    moved = placed[:, None, :, :] + np.c_[shifts, np.zeros(len(shifts))][None, :, None, :]
    gap, _ = SampleTree(points).query(moved.reshape(-1, 3), distance_upper_bound=support)
    return np.isfinite(gap).reshape(-1, placed.shape[1]).sum(axis=1)


@pytest.mark.parametrize("seed", range(4))
def test_every_count_equals_the_k_d_tree_query(seed):
    """Not only the winner: each turn's and shift's count, on noisy points around random samples."""
    from bim2rdt.verify.kernels import shift_counts

    rng = np.random.default_rng(seed)
    placed = rng.uniform(0.0, 0.6, (3, 80, 3))
    points = np.concatenate([placed[0] + rng.normal(0.0, 0.03, (80, 3)), rng.uniform(-0.2, 0.8, (300, 3))])
    steps = np.arange(-0.04, 0.04 + 1e-9, 0.01)
    support = float(rng.uniform(0.02, 0.06))
    located = Located(points)
    counts = shift_counts(placed, steps, True, located.by_height, np.ascontiguousarray(located.by_height[:, 2]),
                          support, support * support)
    want = tree_counts(placed, steps, points, support)
    assert np.array_equal(counts, want) and want.max() > want.min()


def test_a_point_exactly_at_the_bound_is_no_hit():
    """A point exactly ``support`` from a shifted sample is a miss for the k-d trees (distance < bound only), and
    for the count; a hair nearer it is a hit."""
    from bim2rdt.verify.kernels import shift_counts

    steps = np.array([-0.01, 0.0, 0.01])
    placed = np.zeros((1, 1, 3))
    for x, hits in ((0.04, [0, 0, 0, 0, 0, 0, 1, 1, 1]), (np.nextafter(0.04, 0.0), [0, 0, 0, 0, 1, 0, 1, 1, 1])):
        points = np.array([[x, 0.0, 0.0]])
        counts = shift_counts(placed, steps, True, points, points[:, 2].copy(), 0.04, 0.04 * 0.04)
        assert counts.tolist() == hits == tree_counts(placed, steps, points, 0.04).tolist()
        gap, _ = cKDTree(points).query(placed[0] + [[0.0, 0.0, 0.0]], distance_upper_bound=0.04)
        assert np.isfinite(gap).tolist() == [bool(hits[4])]
