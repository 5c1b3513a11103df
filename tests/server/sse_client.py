"""A small server-sent-events reader for the tests (real HTTP through httpx, on a thread)."""

from __future__ import annotations

import json
import threading
import time

import httpx


class StreamReader:
    """Reads /api/stream on a thread; ``messages`` holds (receive time, parsed data) of each event."""

    def __init__(self, url: str, token: str):
        self.url, self.token = url, token
        self.messages: list[tuple[float, dict]] = []
        self.connected = threading.Event()
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)

    def __enter__(self) -> StreamReader:
        self.thread.start()
        assert self.connected.wait(10), "the stream did not open"
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self.thread.join(20)

    def wait_for(self, predicate, timeout_s: float = 10.0):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            for received, message in list(self.messages):
                if predicate(message):
                    return received, message
            time.sleep(0.01)
        raise AssertionError("no such message on the stream")

    def _run(self) -> None:
        headers = {"Authorization": f"Bearer {self.token}"}
        with httpx.Client(timeout=httpx.Timeout(5.0, read=1.0)) as client, \
                client.stream("GET", f"{self.url}/api/stream", headers=headers) as response:
            self.connected.set()
            lines = response.iter_lines()
            while not self._stop.is_set():
                try:
                    line = next(lines)
                except (httpx.ReadTimeout, StopIteration):
                    if self._stop.is_set():
                        return
                    continue
                if line.startswith("data: "):
                    self.messages.append((time.time(), json.loads(line[6:])))
