"""The live stream (GET /api/stream, server-sent events) and the server's two pacing loops.

Messages (SSE ``event`` names): ``safety`` (a HAV monitor event, pushed by the monitor's sink the moment it is
committed), ``workers`` (every worker's exposure, at most once per ``exposure_period_s`` and only when it
changed), ``element`` (a twin record appended by any robot, with the element's new state). Each message's data
is ``{"id", "kind", "sent", "data"}``; ``sent`` is the server's clock when it was published.
"""

from __future__ import annotations

import asyncio
import contextlib
import json

from fastapi import Header, Request
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import StreamingResponse

from bim2rdt.server.hub import Hub
from bim2rdt.server.routes import READ, router

KEEP_ALIVE_S = 15.0
SNAPSHOTS = ("workers",)
"""Kinds that are a whole state: a new client gets the newest one at once."""


@router.get("/stream", openapi_extra=READ, response_class=StreamingResponse,
            responses={200: {"content": {"text/event-stream": {}}}},
            summary="Live changes as server-sent events (safety, workers, element)")
async def stream(request: Request, last_event_id: str | None = Header(None, max_length=20)) -> StreamingResponse:
    hub: Hub = request.app.state.hub
    resume = int(last_event_id) if last_event_id and last_event_id.isdigit() else None
    subscription = hub.subscribe(resume, snapshots=SNAPSHOTS)

    async def body():
        try:
            yield f"retry: 1000\n: connected, last id {hub.last_id}\n\n".encode()
            while not subscription.lost.is_set():
                try:
                    first = await asyncio.wait_for(subscription.queue.get(), KEEP_ALIVE_S)
                except TimeoutError:
                    yield b": keep-alive\n\n"
                    continue
                chunk = [first.encode()]
                while not subscription.queue.empty():  # whatever else is waiting goes in the same write
                    chunk.append(subscription.queue.get_nowait().encode())
                yield b"".join(chunk)
        finally:
            hub.unsubscribe(subscription)

    return StreamingResponse(body(), media_type="text/event-stream",
                             headers={"Cache-Control": "no-store", "X-Accel-Buffering": "no"})


async def poll_twin(view, hub: Hub, period_s: float) -> None:
    """Forward the twin's new records (any robot's) to the stream as ``element`` messages."""
    while True:
        for record, state in await run_in_threadpool(view.changes):
            hub.publish("element", {"record": record, "state": state})
        await asyncio.sleep(period_s)


async def tick_exposure(view, hub: Hub, period_s: float) -> None:
    """Send every worker's exposure when it changed (gauges move between the monitor's events too)."""
    last = None
    while True:
        workers = await run_in_threadpool(view.workers)
        text = json.dumps(workers, sort_keys=True)
        if text != last:
            hub.publish("workers", workers)
            last = text
        await asyncio.sleep(period_s)


@contextlib.asynccontextmanager
async def running(coroutines):
    """Run the loops as tasks for the app's life; cancel them at shutdown."""
    tasks = [asyncio.create_task(c) for c in coroutines]
    try:
        yield
    finally:
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
