"""Fixtures of the planning tests: the embedded site, small built storeys, and the real samples read once."""

from __future__ import annotations

import pytest

from bim2rdt.bim import load_ifc
from bim2rdt.sim.site import build_site_ifc
from planning_buildings import two_rooms


@pytest.fixture(scope="session")
def site_model(tmp_path_factory):
    folder = tmp_path_factory.mktemp("planning-site")
    return load_ifc(build_site_ifc(folder / "site.ifc"), cache_dir=folder / "cache")


@pytest.fixture(scope="session")
def site_grid(site_model):
    from bim2rdt.planning import OccupancyGrid

    return OccupancyGrid.from_bim(site_model)


@pytest.fixture(scope="session")
def building(tmp_path_factory):
    """``building(**options)``: a two-room storey (see planning_buildings.two_rooms), read once per options."""
    folder = tmp_path_factory.mktemp("buildings")
    models = {}

    def load(**options):
        key = repr(sorted(options.items()))
        if key not in models:
            path = two_rooms(folder / f"b{len(models)}.ifc", **options)
            models[key] = load_ifc(path, cache_dir=folder / "cache")
        return models[key]

    return load


@pytest.fixture(scope="session")
def sample_model(samples, tmp_path_factory):
    cache_dir = tmp_path_factory.mktemp("planning-samples")
    models = {}

    def load(name: str):
        if name not in models:
            models[name] = load_ifc(samples / name, cache_dir=cache_dir)
        return models[name]

    return load
