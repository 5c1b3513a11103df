"""Fixtures of the localization tests: the embedded site (BIM) and its as-built scene, and frames rendered in it."""

from __future__ import annotations

import pytest

from bim2rdt.bim import load_ifc
from bim2rdt.sim.site import build_site_ifc
from bim2rdt.sim.tour import tour_scene


@pytest.fixture(scope="session")
def site_model(tmp_path_factory):
    folder = tmp_path_factory.mktemp("site")
    return load_ifc(build_site_ifc(folder / "site.ifc"), cache_dir=folder / "cache")


@pytest.fixture(scope="session")
def built(site_model):
    """The site as built: walls, columns, slab and door as designed, site objects moved, people standing."""
    return tour_scene(site_model, seed=0)


@pytest.fixture(scope="session")
def bare(site_model):
    """The building alone: no site objects and nobody in view."""
    return tour_scene(site_model, seed=0, people=(), site_objects=False)
