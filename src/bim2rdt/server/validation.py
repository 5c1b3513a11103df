"""The answer to a request that fails validation: 422 with where and what (``loc``, ``msg``, ``type``), never the
value sent. FastAPI's default echoes each bad ``input``; a body of ``{"seconds": Infinity}`` (Python's JSON
parser reads Infinity, NaN and 1e400 as floats that are not finite) then cannot be encoded as JSON, and the
request failed with 500. Nor does a refused value need to travel back to whoever sent it."""

from __future__ import annotations

from fastapi import Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse


async def validation_failed(request: Request, error: RequestValidationError) -> JSONResponse:
    detail = [{"loc": [part if isinstance(part, int) else str(part) for part in e.get("loc", ())],
               "msg": str(e.get("msg", "invalid")), "type": str(e.get("type", "value_error"))}
              for e in error.errors()]
    return JSONResponse({"detail": detail}, status_code=422)
