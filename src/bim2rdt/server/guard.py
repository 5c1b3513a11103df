"""Who may call what: a middleware that turns away any /api/ request without a valid bearer token (401) before
routing, and a route class that checks the role each route declares (403) and rate-limits writes (429) before
the request body is even read. So a caller without the right role learns nothing, not even whether a path,
a worker or a body shape exists.

A route declares its roles as ``openapi_extra={"x-roles": [...]}`` (they appear in the OpenAPI document); a
route that declares none is refused to everyone (fail closed).
"""

from __future__ import annotations

import json

from fastapi import HTTPException, Request
from fastapi.routing import APIRoute

from bim2rdt.server.auth import Principal, TokenBook, bearer

OPEN_PATHS = frozenset({"/api/health"})
WRITE_METHODS = frozenset({"POST", "PUT", "PATCH", "DELETE"})


class BearerMiddleware:
    """401 for any /api/ path (but health) without a valid token; the Principal goes into ``request.state``."""

    def __init__(self, app, tokens: TokenBook):
        self.app, self.tokens = app, tokens

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http" or not scope["path"].startswith("/api/") or scope["path"] in OPEN_PATHS:
            return await self.app(scope, receive, send)
        header = dict(scope.get("headers") or []).get(b"authorization", b"").decode("latin-1")
        principal = self.tokens.holder(bearer(header))
        if principal is None:
            return await _refuse(send, 401, "missing or invalid bearer token",
                                 [(b"www-authenticate", b'Bearer realm="bim2rdt"')])
        scope.setdefault("state", {})["principal"] = principal
        await self.app(scope, receive, send)


class RoleRoute(APIRoute):
    """An APIRoute that checks the declared roles, then the write rate, before anything else runs."""

    def get_route_handler(self):
        handler = super().get_route_handler()
        roles = frozenset((self.openapi_extra or {}).get("x-roles", ()))
        writes = bool(self.methods & WRITE_METHODS)

        async def guarded(request: Request):
            principal: Principal | None = getattr(request.state, "principal", None)
            if principal is None or principal.role not in roles:
                raise HTTPException(403, "your role may not use this endpoint")
            if writes:
                wait = request.app.state.limiter.take(principal.name)
                if wait > 0:
                    raise HTTPException(429, "too many requests", {"Retry-After": str(max(1, round(wait)))})
            return await handler(request)

        return guarded


async def _refuse(send, status: int, detail: str, headers: list[tuple[bytes, bytes]]) -> None:
    body = json.dumps({"detail": detail}).encode()
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode()),
                            *headers]})
    await send({"type": "http.response.body", "body": body})
