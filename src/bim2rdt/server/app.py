"""``create_app``: the FastAPI application of the dashboard and its API.

```python
app = create_app(twin, monitor, identity=IdentityMap(path, role="safety"), config=ServerConfig(tokens=[...]),
                 audit_log=Path("var/server/audit.jsonl"))
uvicorn.run(app, host=config.host, port=config.port)
```

``twin`` is a ``DigitalTwin`` (or None), ``monitor`` a ``HavMonitor`` (or None): the app adds a sink to the
monitor so its events reach the live stream as they are committed. The page is the bundle in ``static/``
(built by ``make web`` from ``web/``); it loads nothing from elsewhere, and its Content-Security-Policy says so.
The API docs at ``/docs`` are Swagger UI from the same bundle (``static/swagger``: the npm package swagger-ui-dist),
under a policy as strict; FastAPI's own docs pages (Swagger UI and ReDoc from a CDN) are off.
"""

from __future__ import annotations

import asyncio
import contextlib
import html
from pathlib import Path
from typing import TYPE_CHECKING

from fastapi import FastAPI
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, HTMLResponse
from fastapi.staticfiles import StaticFiles

from bim2rdt import __version__
from bim2rdt.server.audit import AuditLog
from bim2rdt.server.auth import TokenBook
from bim2rdt.server.clock import WALL_CLOCK, SourceClock
from bim2rdt.server.config import ServerConfig
from bim2rdt.server.guard import BearerMiddleware
from bim2rdt.server.hub import Hub, HubSink
from bim2rdt.server.limits import ApiHeadersMiddleware, BodyLimitMiddleware, RateLimiter
from bim2rdt.server.validation import validation_failed

if TYPE_CHECKING:
    from bim2rdt.safety import HavMonitor, IdentityMap
    from bim2rdt.twin import DigitalTwin

STATIC = Path(__file__).parent / "static"
CSP = ("default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data: blob:; "
       "connect-src 'self'; worker-src 'self' blob:; object-src 'none'; base-uri 'none'; frame-ancestors 'none'")
"""The page may load and connect to this server only."""
DOCS_CSP = ("default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data:; connect-src 'self'; "
            "object-src 'none'; base-uri 'none'; frame-ancestors 'none'")
"""The API docs page (Swagger UI) may load and connect to this server only (its CSS draws icons as data: SVG)."""
DOCS_PAGE = """<!doctype html>
<html lang="en">
<head><meta charset="utf-8"><title>{title} API</title><link rel="icon" href="data:,">
<link rel="stylesheet" href="/swagger/swagger-ui.css"></head>
<body><div id="swagger-ui" data-spec="{spec}"></div>
<script src="/swagger/swagger-ui-bundle.js"></script><script src="/swagger/swagger-init.js"></script></body>
</html>
"""


def create_app(twin: DigitalTwin | None = None, monitor: HavMonitor | None = None, *,
               identity: IdentityMap | None = None, config: ServerConfig = ServerConfig(),
               audit_log: Path | AuditLog | None = None, hub: Hub | None = None, record_safety: bool = False,
               clock: SourceClock = WALL_CLOCK) -> FastAPI:
    """The app over a twin and/or a HAV monitor; ``identity`` (an IdentityMap with role 'safety') enables
    revealing identities; ``audit_log`` (a path, or an AuditLog) defaults to ``config.audit_log`` (required one
    way or the other). With
    ``record_safety`` the monitor's events also go into the twin's history (through the view's lock, so the
    server's reads never interleave with the monitor thread's writes). ``clock``: the sources' clock the page
    shows (a demo's simulated day; default the wall clock).

    Args:
        twin: The twin whose state and history the API serves; None when there is none.
        monitor: The HAV monitor whose exposures and events the API serves; None when there is none.
        identity: An IdentityMap opened with role ``safety``: enables revealing identities.
        config: Tokens, limits and timeouts of the server.
        audit_log: Where revealed identities are logged: a path or an AuditLog; None uses ``config.audit_log``.
        hub: The stream hub of server-sent events; None makes one.
        record_safety: Also record the monitor's events in the twin's history.
        clock: The sources' clock the page shows.

    Returns:
        The FastAPI app.

    Raises:
        ValueError: No audit log, neither as ``audit_log`` nor in ``config``.
    """
    from bim2rdt.server.safety_view import SafetyView
    from bim2rdt.server.stream import poll_twin, running, tick_exposure
    from bim2rdt.server.twin_view import TwinView

    hub = hub or Hub(backlog=config.stream_backlog)
    twin_view = TwinView(twin) if twin is not None else None
    safety_view = SafetyView(monitor.queries, identity) if monitor is not None else None
    if monitor is not None:
        monitor.sinks.append(HubSink(hub))  # first: the stream hears of an event before anything slower runs
        if record_safety and twin_view is not None:
            monitor.add_sink(twin_view.safety_sink())  # durable: through the monitor's outbox
    path = audit_log or config.audit_log
    if path is None:
        raise ValueError("create_app needs an audit log path (audit_log= or config.audit_log)")

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI):
        hub.bind(asyncio.get_running_loop())
        loops = [poll_twin(twin_view, hub, config.twin_poll_s)] if twin_view else []
        loops += [tick_exposure(safety_view, hub, config.exposure_period_s)] if safety_view else []
        async with running(loops):
            yield
        if safety_view is not None:
            safety_view.close()

    app = FastAPI(title="bim2rdt", version=__version__, lifespan=lifespan, docs_url=None, redoc_url=None,
                  description="The live digital twin of the site and hand-arm vibration exposure. Every /api path "
                  "but /api/health needs a bearer token (roles: viewer, safety, admin).")
    app.state.twin, app.state.safety, app.state.hub, app.state.config = twin_view, safety_view, hub, config
    app.state.clock = clock
    app.state.audit = path if isinstance(path, AuditLog) else AuditLog(path)
    app.state.rate_audited = {}
    app.state.limiter = RateLimiter(config.write_rate_per_minute)
    app.add_exception_handler(RequestValidationError, validation_failed)
    _add_routes(app)
    app.add_middleware(BearerMiddleware, tokens=TokenBook((t.name, t.role, t.sha256) for t in config.tokens))
    app.add_middleware(BodyLimitMiddleware, max_bytes=config.max_body_bytes)
    app.add_middleware(ApiHeadersMiddleware)  # last added: outermost
    return app


def _add_routes(app: FastAPI) -> None:
    from bim2rdt.server import stream  # noqa: F401  (registers /api/stream on the router)
    from bim2rdt.server.routes import open_router, router

    app.include_router(open_router)
    app.include_router(router)
    if (STATIC / "assets").is_dir():
        app.mount("/assets", StaticFiles(directory=STATIC / "assets"), name="assets")

    @app.get("/", include_in_schema=False)
    def index():
        page = STATIC / "index.html"
        if not page.is_file():
            return HTMLResponse("<p>The dashboard is not built: run <code>make web</code>.</p>", 503)
        return FileResponse(page, headers={"Content-Security-Policy": CSP, "Cache-Control": "no-cache"})

    if (STATIC / "swagger").is_dir():
        app.mount("/swagger", StaticFiles(directory=STATIC / "swagger"), name="swagger")

    @app.get("/docs", include_in_schema=False)
    def docs():
        if not (STATIC / "swagger").is_dir():
            return HTMLResponse("<p>The API docs are not built: run <code>make web</code>.</p>", 503)
        page = DOCS_PAGE.format(title=html.escape(app.title), spec=html.escape(app.openapi_url))
        return HTMLResponse(page, headers={"Content-Security-Policy": DOCS_CSP, "Cache-Control": "no-cache"})
