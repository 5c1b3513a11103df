"""Fixtures of the BIM tests: the embedded site built once, and each real sample read once per session
(Office_A alone tessellates for ~7 s), each with its own cache folder."""

from __future__ import annotations

import pytest

from bim2rdt.bim import load_ifc
from bim2rdt.sim.site import build_site_ifc


@pytest.fixture(scope="session")
def site_ifc(tmp_path_factory):
    """The default construction site as an IFC4 file (read-only for tests: copy it before writing)."""
    return build_site_ifc(tmp_path_factory.mktemp("site") / "site.ifc")


@pytest.fixture(scope="session")
def site_model(site_ifc, tmp_path_factory):
    return load_ifc(site_ifc, cache_dir=tmp_path_factory.mktemp("site-cache"))


@pytest.fixture(scope="session")
def sample_model(samples, tmp_path_factory):
    """load_ifc of a shared sample by file name, tessellated once per session."""
    cache_dir = tmp_path_factory.mktemp("samples-cache")
    models = {}

    def load(name: str):
        if name not in models:
            models[name] = load_ifc(samples / name, cache_dir=cache_dir)
        return models[name]

    return load
