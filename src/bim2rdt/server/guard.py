"""Who may call what: a middleware that turns away any /api/ request without a valid bearer token (401) before
routing, and a route class that checks the role each route declares (403) and rate-limits writes (429) before
the request body is even read. So a caller without the right role learns nothing, not even whether a path,
a worker or a body shape exists.

A route declares its roles as ``openapi_extra={"x-roles": [...]}`` (they appear in the OpenAPI document); a
route that declares none is refused to everyone (fail closed). A reveal route also declares ``"x-audit": action``:
its refusals (403 role, 429 rate) are written to the audit log too, before they are answered. A write is
rate-limited before its role is checked, so a token probing a reveal it may not make writes at most the rate's
worth of refusals a minute into the log (and 429 refusals are recorded once a minute per token).
"""

from __future__ import annotations

import json
import time

from fastapi import HTTPException, Request
from fastapi.concurrency import run_in_threadpool
from fastapi.routing import APIRoute

from bim2rdt.server.audit import AuditError
from bim2rdt.server.auth import Principal, TokenBook, bearer

OPEN_PATHS = frozenset({"/api/health"})
WRITE_METHODS = frozenset({"POST", "PUT", "PATCH", "DELETE"})
RATE_AUDIT_EVERY_S = 60.0
"""A token's 429 refusals of a reveal are audited at most once in this many seconds."""
UNAUDITED = "the audit log cannot be written: nothing was revealed"


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
        audited = (self.openapi_extra or {}).get("x-audit")

        async def guarded(request: Request):
            principal: Principal | None = getattr(request.state, "principal", None)
            if principal is None:
                raise HTTPException(403, "your role may not use this endpoint")
            if writes:
                wait = request.app.state.limiter.take(principal.name)
                if wait > 0:
                    if audited and _rate_audit_due(request, principal.name):
                        await audit_refusal(request, audited, "refused: rate")
                    raise HTTPException(429, "too many requests", {"Retry-After": str(max(1, round(wait)))})
            if principal.role not in roles:
                if audited:
                    await audit_refusal(request, audited, "refused: role")
                raise HTTPException(403, "your role may not use this endpoint")
            return await handler(request)

        return guarded


async def audit_refusal(request: Request, action: str, outcome: str, why: str = "") -> None:
    """Record a refused reveal (its subject as the path gave it, cut to 64 characters); 503 if it cannot be."""
    await write_audit(request, action, str(request.path_params.get("subject", ""))[:64], why, {}, outcome)


async def write_audit(request: Request, action: str, subject: str, why: str, detail: dict,
                      outcome: str = "revealed") -> None:
    """Append one record for the request's principal; HTTPException 503 when the log cannot take it."""
    principal = request.state.principal
    try:
        await run_in_threadpool(request.app.state.audit.append, principal.name, principal.role, action, subject,
                                why, detail, outcome)
    except AuditError:
        raise HTTPException(503, UNAUDITED) from None


def _rate_audit_due(request: Request, name: str) -> bool:
    audited = request.app.state.rate_audited
    now = time.monotonic()
    if now - audited.get(name, -RATE_AUDIT_EVERY_S) < RATE_AUDIT_EVERY_S:
        return False
    audited[name] = now
    return True


async def _refuse(send, status: int, detail: str, headers: list[tuple[bytes, bytes]]) -> None:
    body = json.dumps({"detail": detail}).encode()
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode()),
                            *headers]})
    await send({"type": "http.response.body", "body": body})
