"""The localization tour of the embedded site: 100 m of stations, and a scene with the building in it."""

from __future__ import annotations

import numpy as np

from bim2rdt.sim.tour import tour_poses


def test_the_default_tour_walks_at_least_100_m_through_the_building():
    poses = tour_poses()
    walked = sum(np.linalg.norm(b[:2, 3] - a[:2, 3]) for a, b in zip(poses[:-1], poses[1:]))
    assert 100.0 <= walked < 110.0
    inside = np.array([T[:2, 3] for T in poses])
    assert np.all((inside > 0.3) & (inside < [19.7, 13.7]))
    assert np.allclose([T[2, 3] for T in poses], 1.1)
