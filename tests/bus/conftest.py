"""A real Mosquitto broker with the project's shipped config (password per device + ACL) on a free port."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from bim2rdt.bus.broker import MOSQUITTO, MosquittoBroker

SITE = "s"
MONITORS = ("monitor", "monitor-acks", "monitor-auto", "monitor-poison", "monitor-fuzz")
"""Monitor users: with client ids bound to usernames, tests that keep a persistent session use their own."""
USERS = {**{user: f"{user}-pw" for user in MONITORS}, "dashboard": "dash-pw", "w1": "w1-pw", "w2": "w2-pw", "w3": "w3-pw",
         "w4": "w4-pw", "w5": "w5-pw"}


@pytest.fixture(scope="session")
def broker(tmp_path_factory):
    """Mosquitto on 127.0.0.1:<free port> (never 1883) with the ACL of site "s", started for the session and
    stopped after."""
    if not Path(MOSQUITTO).exists() or shutil.which("mosquitto_passwd") is None:
        pytest.fail("Debian's mosquitto is required for the bus tests (.ci/run installs it)")
    with MosquittoBroker(USERS, folder=tmp_path_factory.mktemp("mosquitto"), site=SITE, monitors=MONITORS) as running:
        yield running


NATS_DEVICES = {f"w{i}": f"w{i}-pw" for i in range(1, 7)}
NATS_MONITORS = {"monitor": "monitor-pw"}


@pytest.fixture
def nats_server(tmp_path):
    """nats-server (Debian's) with JetStream and MQTT on free loopback ports, site "s", 3 partitions; one per test
    (its JetStream files go with it)."""
    from bim2rdt.bus.nats_broker import NATS_SERVER, NatsServer

    if not Path(NATS_SERVER).exists():
        pytest.fail("Debian's nats-server is required for the NATS tests (.ci/run installs it)")
    with NatsServer(SITE, NATS_DEVICES, NATS_MONITORS, partitions=3, folder=tmp_path / "nats") as running:
        yield running
