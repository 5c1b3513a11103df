"""Fixtures of the server tests: the app over a recorded twin and a fed HAV monitor, served by uvicorn on a free
port (real HTTP), and a token per role."""

from __future__ import annotations

import os
from pathlib import Path

import httpx
import pytest

from server_helpers import (CHROMIUM, SITE_SECRET, config_with_tokens, family_mesh, feed, record_day, today_since,
                            vibration)


@pytest.fixture
def twin(tmp_path, site_model):
    from bim2rdt.twin import DigitalTwin

    with DigitalTwin.open(f"sqlite:///{tmp_path / 'twin.db'}", site_model, family_mesh=family_mesh) as twin:
        twin.ids = record_day(twin, site_model)
        yield twin


@pytest.fixture
def monitor(tmp_path):
    """A monitor with one worker an hour into the day, a grinder running at ~6 m/s^2 (below the EAV)."""
    from bim2rdt.safety import HavMonitor, IdentityMap, MonitorConfig

    monitor = HavMonitor(tmp_path / "hav", SITE_SECRET, config=MonitorConfig(site="test"))
    monitor.start_session("dev-1", "anna.berg", "grinder", zone="Work zone A")
    feed(monitor, vibration("dev-1", 20.0, 6.0, today_since(60, 90)))  # later feeds follow it
    monitor.identity_for_server = IdentityMap(tmp_path / "hav" / "private" / "identity.sqlite", role="safety")
    yield monitor
    monitor.identity_for_server.close()
    monitor.close()


@pytest.fixture
def served(tmp_path, twin, monitor):
    """(base URL, {role: token}, app) of the app over ``twin`` and ``monitor`` on a free port."""
    from bim2rdt.server import create_app
    from bim2rdt.server.runner import ServerThread

    config, tokens = config_with_tokens(tmp_path)
    app = create_app(twin, monitor, identity=monitor.identity_for_server, config=config)
    with ServerThread(app) as server:
        yield server.url, tokens, app


@pytest.fixture
def client(served):
    url, tokens, _ = served
    with httpx.Client(base_url=url, timeout=30) as http:
        http.tokens = tokens
        yield http


@pytest.fixture
def chromium() -> str:
    """Debian's Chromium; in CI (where .ci/run installs it) its absence fails the test instead of skipping it."""
    if not Path(CHROMIUM).exists():
        message = f"{CHROMIUM} is absent (apt-get install chromium; .ci/run does)"
        pytest.fail(message) if os.environ.get("CI") else pytest.skip(message)
    return CHROMIUM
