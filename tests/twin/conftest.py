"""Fixtures of the twin tests: the embedded site, and a twin URL on each backend (SQLite file; PostgreSQL)."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

from bim2rdt.bim import load_ifc
from bim2rdt.sim.meshes import mesh_for_family
from bim2rdt.sim.site import build_site_ifc

from postgres_server import ENV_URL, fresh_database, pg_bindir, private_cluster

SYMMETRY = {"Traffic_Cone_Orange_70cm": 4, "Steel_Drum_55gal": math.inf, "Pallet_Wood_EUR": 2}
T0 = 1_780_000_000.0
"""A site time (UTC s) the tests start from."""


@pytest.fixture(scope="session")
def site_ifc(tmp_path_factory):
    return build_site_ifc(tmp_path_factory.mktemp("site") / "site.ifc")


@pytest.fixture(scope="session")
def site_model(site_ifc, tmp_path_factory):
    return load_ifc(site_ifc, cache_dir=tmp_path_factory.mktemp("site-cache"))


@pytest.fixture(scope="session")
def postgres_admin_url():
    """The PostgreSQL server of the session: CI's (its URL in $BIM2RDT_TEST_POSTGRES_URL), else a private one.
    In CI a missing server fails the suite: these tests are never silently skipped there."""
    if url := os.environ.get(ENV_URL):
        yield url
        return
    bindir = pg_bindir()
    if bindir is None:
        message = f"no PostgreSQL: set {ENV_URL} or install Debian's postgresql (.ci/run does)"
        pytest.fail(message) if os.environ.get("CI") else pytest.skip(message)
    with private_cluster(bindir) as url:
        yield url


@pytest.fixture(params=["sqlite", pytest.param("postgresql", marks=pytest.mark.postgres)])
def twin_url(request, tmp_path):
    """A URL of an empty twin store on each backend."""
    if request.param == "sqlite":
        yield f"sqlite:///{tmp_path / 'twin.db'}"
        return
    with fresh_database(request.getfixturevalue("postgres_admin_url")) as url:
        yield url


def family_mesh(family: str):
    mesh = mesh_for_family(family)
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)
