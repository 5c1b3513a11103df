"""Fixtures of the BIM tests: each real sample read once per session (Office_A alone tessellates for ~7 s), with
its own cache folder. The embedded site (``site_ifc``, ``site_model``) comes from tests/conftest.py."""

from __future__ import annotations

import pytest

from bim2rdt.bim import load_ifc


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
