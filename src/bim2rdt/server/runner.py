"""Running the app with uvicorn: in the foreground (``bim2rdt serve``) or on a background thread (tests, the
server benchmark), on a given port or any free one."""

from __future__ import annotations

import threading
import time

import uvicorn

GRACE_S = 2.0
"""Seconds open streams get at shutdown before they are cut."""


class ServerThread:
    """Serves ``app`` on ``host``:``port`` (0: a free port) in a daemon thread; ``url`` once started."""

    def __init__(self, app, host: str = "127.0.0.1", port: int = 0):
        config = uvicorn.Config(app, host=host, port=port, log_level="warning", lifespan="on",
                                timeout_graceful_shutdown=GRACE_S, access_log=False)
        self.server = uvicorn.Server(config)
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
    uvicorn.run(app, host=host, port=port, log_level="warning", lifespan="on", timeout_graceful_shutdown=GRACE_S)
