"""The localization tour of the embedded site: 100 m of stations, and a scene with the building in it."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.bim import load_ifc
from bim2rdt.sim.site import build_site_ifc
from bim2rdt.sim.tour import tour_poses, tour_scene


@pytest.fixture(scope="module")
def site_model(tmp_path_factory):
    folder = tmp_path_factory.mktemp("site")
    return load_ifc(build_site_ifc(folder / "site.ifc"), cache_dir=folder / "cache")


def test_the_default_tour_walks_at_least_100_m_through_the_building():
    poses = tour_poses()
    walked = sum(np.linalg.norm(b[:2, 3] - a[:2, 3]) for a, b in zip(poses[:-1], poses[1:]))
    assert 100.0 <= walked < 110.0
    inside = np.array([T[:2, 3] for T in poses])
    assert np.all((inside > 0.3) & (inside < [19.7, 13.7]))
    assert np.allclose([T[2, 3] for T in poses], 1.1)


def test_a_building_set_out_to_tolerance_stands_off_its_bim_by_about_that(site_model):
    exact = tour_scene(site_model, seed=0, people=(), site_objects=False).scene.building
    built = tour_scene(site_model, seed=0, people=(), site_objects=False, tolerance=0.01).scene.building
    again = tour_scene(site_model, seed=0, people=(), site_objects=False, tolerance=0.01).scene.building
    shifts = np.array([b.mesh.centroid - e.mesh.centroid for b, e in zip(built, exact)])
    assert 0.003 < np.sqrt(np.mean(shifts**2)) < 0.03
    assert np.allclose([b.mesh.centroid for b in built], [a.mesh.centroid for a in again])
