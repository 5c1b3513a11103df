"""Helpers for the safety tests: a monitor on a fresh folder and simulated tool sessions."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from bim2rdt.safety import HavMonitor, ListSink, MonitorConfig

from hav_helpers import Clock

@pytest.fixture
def clock() -> Clock:
    return Clock()


@pytest.fixture
def make_monitor(tmp_path, clock) -> Callable[..., tuple[HavMonitor, ListSink]]:
    """Build a monitor in tmp_path/folder (the same folder again is a restart)."""
    made = []

    def make(folder: str = "data", **config) -> tuple[HavMonitor, ListSink]:
        sink = ListSink()
        monitor = HavMonitor(tmp_path / folder, "test-secret", [sink], MonitorConfig(**config), clock)
        made.append(monitor)
        return monitor, sink

    yield make
    for monitor in made:
        monitor.close()




@pytest.fixture(params=["sqlite", pytest.param("postgresql", marks=pytest.mark.postgres)])
def store_url(request, tmp_path):
    """A URL of an empty exposure store on each backend (an SQLite file; a fresh PostgreSQL database)."""
    if request.param == "sqlite":
        yield f"sqlite:///{tmp_path / 'shared' / 'hav.sqlite'}"
        return
    from postgres_server import fresh_database

    with fresh_database(request.getfixturevalue("postgres_admin_url")) as url:
        yield url
