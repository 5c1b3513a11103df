"""Connections are bounded: a socket that sends no whole request head within the header timeout is closed,
sockets beyond the cap are answered 503 at once and closed (their file descriptors never pile up), and through a
flood of idle and half-sent sockets a fresh client still gets /api/health. All on 127.0.0.1, in bounded loops."""

from __future__ import annotations

import socket
import time

import httpx
import pytest

from server_helpers import config_with_tokens

CAP, HEADER_TIMEOUT_S = 16, 1.0
FLOOD = 3 * CAP
"""Sockets opened: three times the cap, half idle, half with a request head never finished."""


@pytest.fixture
def capped(tmp_path):
    from bim2rdt.server import create_app
    from bim2rdt.server.runner import ServerThread

    config, _ = config_with_tokens(tmp_path, max_connections=CAP, header_timeout_s=HEADER_TIMEOUT_S)
    with ServerThread(create_app(config=config)) as server:
        yield server


def _flood(port: int) -> list[socket.socket]:
    sockets = []
    for k in range(FLOOD):
        s = socket.create_connection(("127.0.0.1", port), timeout=5)
        if k % 2:
            s.sendall(b"GET /api/health HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: ")  # a head never finished
        sockets.append(s)
    return sockets


def _closed_by_server(s: socket.socket, within_s: float) -> bool:
    """True when the server closed the socket (EOF, possibly after a 503) within ``within_s`` seconds."""
    s.settimeout(within_s)
    try:
        while chunk := s.recv(4096):
            if not chunk:
                break
        return True
    except (TimeoutError, socket.timeout):
        return False
    except ConnectionResetError:
        return True


def test_a_flood_of_idle_and_half_sent_sockets_leaves_health_answering(capped):
    sockets = _flood(capped.port)
    try:
        started = time.monotonic()
        first = httpx.get(f"{capped.url}/api/health", timeout=5)  # at once: answered (503 while over the cap)
        assert first.status_code in (200, 503) and time.monotonic() - started < 2.0
        deadline, health = time.monotonic() + HEADER_TIMEOUT_S + 10, None
        while time.monotonic() < deadline:
            try:
                health = httpx.get(f"{capped.url}/api/health", timeout=2)
                if health.status_code == 200:
                    break
            except httpx.HTTPError:
                pass
            time.sleep(0.2)
        assert health is not None and health.status_code == 200, health
        assert all(_closed_by_server(s, HEADER_TIMEOUT_S + 5) for s in sockets)  # none held open
    finally:
        for s in sockets:
            s.close()


def test_sockets_beyond_the_cap_get_503_at_once(capped):
    sockets = [socket.create_connection(("127.0.0.1", capped.port), timeout=5) for _ in range(CAP + 4)]
    try:
        time.sleep(0.2)
        extra = socket.create_connection(("127.0.0.1", capped.port), timeout=5)
        extra.settimeout(2)
        assert extra.recv(100).startswith(b"HTTP/1.1 503")
        extra.close()
    finally:
        for s in sockets:
            s.close()


def test_the_connection_limits_are_settings_of_the_server():
    from bim2rdt.server import ServerConfig

    config = ServerConfig()
    assert 0 < config.header_timeout_s <= 30 and 8 <= config.max_connections <= 4096
    assert config.keep_alive_s >= 1 and config.max_header_bytes >= 4096
