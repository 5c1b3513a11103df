"""Partitions started together on a fresh PostgreSQL store: each creates the schema, and none fails."""

from __future__ import annotations

import subprocess
import sys

import pytest

OPEN_STORE = "import sys; from bim2rdt.safety.store import ExposureStore; ExposureStore(sys.argv[1]).close()"


@pytest.mark.parametrize("attempt", range(2))
def test_processes_opening_a_fresh_postgresql_store_together_all_create_or_find_its_schema(postgres_admin_url,
                                                                                           attempt):
    from postgres_server import fresh_database

    with fresh_database(postgres_admin_url) as url:
        starts = [subprocess.Popen([sys.executable, "-c", OPEN_STORE, url], stderr=subprocess.PIPE, text=True)
                  for _ in range(6)]
        failures = [process.communicate(timeout=120)[1] for process in starts if process.wait(timeout=120) != 0]
    assert failures == []
