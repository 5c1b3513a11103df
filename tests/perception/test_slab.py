"""Dropping the slab's points from an ROI, and what that buys the registration scenarios."""

from __future__ import annotations

import numpy as np

from bim2rdt.perception.slab import SLAB_CLEARANCE, off_the_slab
from bim2rdt.sim.scenarios import scenario


def test_points_within_the_clearance_of_the_slab_are_dropped_and_the_rest_kept_in_order():
    points = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.5], [2.0, 0.0, SLAB_CLEARANCE * 0.9],
                       [3.0, 0.0, -0.01], [4.0, 0.0, SLAB_CLEARANCE * 1.1]])
    kept = off_the_slab(points)
    assert np.array_equal(kept, points[[1, 4]])


def test_the_slab_height_and_up_direction_are_honoured():
    points = np.array([[0.0, 0.0, 2.0], [0.0, 0.0, 2.5], [0.0, 0.3, 0.0], [0.0, 2.5, 0.0]])
    assert np.array_equal(off_the_slab(points[:2], slab_height=2.0), points[1:2])
    assert np.array_equal(off_the_slab(points[2:], up=np.array([0.0, 1.0, 0.0])), points[2:])
    assert np.array_equal(off_the_slab(points[2:], slab_height=0.5, up=np.array([0.0, 1.0, 0.0])), points[3:])


def test_a_view_with_too_few_points_above_the_slab_keeps_them_all():
    flat = np.c_[np.arange(10.0), np.zeros(10), np.full(10, 0.005)]
    assert len(off_the_slab(flat, least=6)) == 10
    assert len(off_the_slab(flat)) == 0


def test_scenario_points_are_off_the_slab():
    """The benchmark's scene points go through the same slab filter as the mission's: before it, a tripod's
    ROI points were ~90 % floor corners."""
    built = scenario("S4", trials=2, views=1)
    for trial in built.trials:
        for obj in trial:
            assert obj.scene_pts_world[:, 2].min() > SLAB_CLEARANCE
