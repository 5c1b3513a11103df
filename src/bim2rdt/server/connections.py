"""Bounded connections: uvicorn's h11 protocol with a deadline for each request head and a hard cap.

uvicorn closes a keep-alive connection that stays idle after a response, but a socket that connects and sends
nothing, or half a request head, is held for ever; 300 of them took the server to its file limit, where asyncio
logged a traceback per failed accept. So here:

- a connection gets ``header_timeout_s`` to send a whole request head, from when it opened or its last response
  ended; then it is closed (the slow-loris and the idle socket alike);
- a connection beyond ``max_connections`` is answered 503 and closed at once, so the descriptors in use stay
  bounded and a fresh client is told to retry instead of hanging (uvicorn's ``limit_concurrency``, set to the
  same cap, answers 503 to requests beyond it as well).

A request whose head has arrived is not timed here (bodies are capped by ``BodyLimitMiddleware``; the live
stream is meant to stay open).
"""

from __future__ import annotations

import asyncio

from uvicorn.protocols.http.h11_impl import H11Protocol

BUSY = (b"HTTP/1.1 503 Service Unavailable\r\ncontent-type: text/plain; charset=utf-8\r\nconnection: close\r\n"
        b"retry-after: 1\r\ncontent-length: 37\r\n\r\ntoo many connections: retry shortly\r\n")


def bounded_protocol(header_timeout_s: float, max_connections: int) -> type[H11Protocol]:
    """An H11Protocol class with these bounds (uvicorn builds one instance per connection)."""

    class BoundedH11Protocol(H11Protocol):
        _head_timer: asyncio.TimerHandle | None = None

        def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
            super().connection_made(transport)
            if len(self.connections) > max_connections:
                transport.write(BUSY)
                transport.close()
                return
            self._await_head()

        def on_response_complete(self) -> None:
            super().on_response_complete()
            self._await_head()

        def connection_lost(self, exc: Exception | None) -> None:
            self._stop_timer()
            super().connection_lost(exc)

        def _await_head(self) -> None:
            self._stop_timer()
            if not self.transport.is_closing():
                self._head_timer = self.loop.call_later(header_timeout_s, self._head_overdue)

        def _head_overdue(self) -> None:
            self._head_timer = None
            waiting = self.cycle is None or self.cycle.response_complete
            if waiting and not self.transport.is_closing():
                self.transport.close()

        def _stop_timer(self) -> None:
            if self._head_timer is not None:
                self._head_timer.cancel()
                self._head_timer = None

    return BoundedH11Protocol
