"""Fixtures of the twin tests: a twin URL on each backend (SQLite file; PostgreSQL). ``site_model`` comes from
tests/conftest.py, shared values from twin_helpers.py."""

from __future__ import annotations

import os

import pytest

from postgres_server import ENV_URL, fresh_database, pg_bindir, private_cluster


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
