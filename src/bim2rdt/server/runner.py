"""Running the app with uvicorn: in the foreground (``bim2rdt serve``) or on a background thread (tests, the
server benchmark), on a given port or any free one, with the connection bounds of the app's ``ServerConfig``
(see ``connections``)."""

from __future__ import annotations

import resource
import socket
import threading
import time

import uvicorn

from bim2rdt.errors import Bim2RdtError
from bim2rdt.server.config import ServerConfig
from bim2rdt.server.connections import bounded_protocol

GRACE_S = 2.0
"""Seconds open streams get at shutdown before they are cut."""
SPARE_FILES = 256
"""File descriptors kept beyond the connection cap (stores, logs, the static files)."""


class ListenError(Bim2RdtError):
    """The server cannot listen where it was asked to (a busy port, a host that is not this machine's)."""


def listening_socket(host: str, port: int) -> socket.socket:
    """A TCP socket bound to ``host``:``port`` and listening (port 0: a free one); ListenError in one line
    otherwise. Bound before anything slow starts, so a busy port is said at once."""
    where = f"{host}:{port}"
    try:
        family, kind, proto, _, address = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM,
                                                              flags=socket.AI_PASSIVE)[0]
    except (OSError, UnicodeError) as error:
        raise ListenError(f"cannot listen on {where}: {getattr(error, 'strerror', None) or error}") from None
    sock = socket.socket(family, kind, proto)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(address)
        sock.listen(2048)
    except OSError as error:
        sock.close()
        raise ListenError(f"cannot listen on {where}: {error.strerror or error}") from None
    return sock


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

    def __init__(self, app, host: str = "127.0.0.1", port: int = 0, sock: socket.socket | None = None):
        """``sock``: a socket from ``listening_socket`` (default: one made here, ListenError if it cannot be)."""
        self.sock = sock or listening_socket(host, port)
        self.server = uvicorn.Server(uvicorn_config(app, host, port))
        self.thread = threading.Thread(target=self.server.run, kwargs={"sockets": [self.sock]},
                                       name="bim2rdt-server", daemon=True)
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
        return self.sock.getsockname()[1]

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}"

    def stop(self) -> None:
        self.server.should_exit = True
        self.thread.join(GRACE_S + 10)
        self.sock.close()

    def __enter__(self) -> ServerThread:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


def serve(app, host: str, port: int) -> None:
    """Serve in the foreground until interrupted (Ctrl-C)."""
    sock = listening_socket(host, port)
    try:
        uvicorn.Server(uvicorn_config(app, host, port)).run(sockets=[sock])
    finally:
        sock.close()


def _enough_files(needed: int) -> None:
    """Raise the soft limit of open files to ``needed`` where the hard limit allows (never lower it)."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft != resource.RLIM_INFINITY and soft < needed:
        target = needed if hard == resource.RLIM_INFINITY else min(needed, hard)
        resource.setrlimit(resource.RLIMIT_NOFILE, (target, hard))
