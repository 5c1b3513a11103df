"""Running the app with uvicorn: in the foreground (``bim2rdt serve``) or on a background thread (tests, the
server benchmark), on a given port or any free one, with the connection bounds of the app's ``ServerConfig``
(see ``connections``)."""

from __future__ import annotations

import resource
import threading
import time

import uvicorn

from bim2rdt.server.config import ServerConfig
from bim2rdt.server.connections import bounded_protocol

GRACE_S = 2.0
"""Seconds open streams get at shutdown before they are cut."""
SPARE_FILES = 256
"""File descriptors kept beyond the connection cap (stores, logs, the static files)."""


def uvicorn_config(app, host: str, port: int) -> uvicorn.Config:
    """uvicorn's settings for ``app``: its ServerConfig's bounds (the defaults when the app has none)."""
    config: ServerConfig = getattr(app.state, "config", None) or ServerConfig()
    _enough_files(config.max_connections + SPARE_FILES)
    return uvicorn.Config(app, host=host, port=port, log_level="warning", lifespan="on", access_log=False,
                          timeout_graceful_shutdown=GRACE_S,
                          http=bounded_protocol(config.header_timeout_s, config.max_connections),
                          limit_concurrency=config.max_connections, timeout_keep_alive=config.keep_alive_s,
                          h11_max_incomplete_event_size=config.max_header_bytes)


class ServerThread:
    """Serves ``app`` on ``host``:``port`` (0: a free port) in a daemon thread; ``url`` once started."""

    def __init__(self, app, host: str = "127.0.0.1", port: int = 0):
        self.server = uvicorn.Server(uvicorn_config(app, host, port))
        self.thread = threading.Thread(target=self.server.run, name="bim2rdt-server", daemon=True)
        self.host = host

    def start(self, timeout_s: float = 30.0) -> ServerThread:
        self.thread.start()
        deadline = time.monotonic() + timeout_s
        while not self.server.started:
            if not self.thread.is_alive() or time.monotonic() > deadline:
                raise RuntimeError(f"the server did not start on {self.host} within {timeout_s:g} s")
            time.sleep(0.02)
        return self

    @property
    def port(self) -> int:
        return self.server.servers[0].sockets[0].getsockname()[1]

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}"

    def stop(self) -> None:
        self.server.should_exit = True
        self.thread.join(GRACE_S + 10)

    def __enter__(self) -> ServerThread:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


def serve(app, host: str, port: int) -> None:
    """Serve in the foreground until interrupted (Ctrl-C)."""
    uvicorn.Server(uvicorn_config(app, host, port)).run()


def _enough_files(needed: int) -> None:
    """Raise the soft limit of open files to ``needed`` where the hard limit allows (never lower it)."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft != resource.RLIM_INFINITY and soft < needed:
        target = needed if hard == resource.RLIM_INFINITY else min(needed, hard)
        resource.setrlimit(resource.RLIMIT_NOFILE, (target, hard))
