"""Fixtures of the twin tests: a twin URL on each backend (SQLite file; PostgreSQL). ``site_model`` and
``postgres_admin_url`` come from tests/conftest.py, shared values from twin_helpers.py."""

from __future__ import annotations

import pytest

from postgres_server import fresh_database


@pytest.fixture(params=["sqlite", pytest.param("postgresql", marks=pytest.mark.postgres)])
def twin_url(request, tmp_path):
    """A URL of an empty twin store on each backend."""
    if request.param == "sqlite":
        yield f"sqlite:///{tmp_path / 'twin.db'}"
        return
    with fresh_database(request.getfixturevalue("postgres_admin_url")) as url:
        yield url
