"""The API's endpoints (all under /api; every one but health needs a bearer token, see ``guard``)."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, Path, Query, Request, Response, Security
from fastapi.concurrency import run_in_threadpool
from fastapi.security import HTTPBearer

from bim2rdt import __version__
from bim2rdt.server.auth import ADMIN, READERS, SAFETY
from bim2rdt.server.guard import RoleRoute, write_audit
from bim2rdt.server.schemas import (AuditEntry, Clock, Element, ElementDetail, Health, Identity, Me, RawRequest,
                                    RawWindows, RefusedMessages, RevealRequest, SafetyEvent, TwinRecord, TwinState,
                                    Worker)

bearer_scheme = HTTPBearer(auto_error=False, description="A token from the server's settings (or the viewer token "
                           "`bim2rdt serve` prints).")
open_router = APIRouter(prefix="/api", tags=["health"])
router = APIRouter(prefix="/api", route_class=RoleRoute, dependencies=[Security(bearer_scheme)],
                   responses={401: {"description": "Missing or invalid bearer token."},
                              403: {"description": "The token's role may not use this endpoint."}})

READ = {"x-roles": sorted(READERS)}
REVEAL_IDENTITY = {"x-roles": [SAFETY], "x-audit": "identity"}
REVEAL_RAW = {"x-roles": [SAFETY], "x-audit": "raw"}
ADMIN_ONLY = {"x-roles": [ADMIN]}
GLOBAL_ID = Path(min_length=1, max_length=64, description="The element's IFC GlobalId (or a new object's id).")
SUBJECT = Path(min_length=3, max_length=64, description="The worker's pseudonym.")
UNAVAILABLE = {503: {"description": "This server has no twin (or no monitor)."}}
AUDITED = {503: {"description": "No monitor, or the audit log cannot be written (nothing is revealed)."},
           429: {"description": "Too many reveals from this token (audited)."}}


@open_router.get("/health", response_model=Health, summary="Is the server up, and what does it serve")
def health(request: Request) -> Health:
    state = request.app.state
    return Health(status="ok", version=__version__, twin=state.twin is not None, monitor=state.safety is not None,
                  stream_clients=state.hub.subscribers)


@router.get("/me", response_model=Me, openapi_extra=READ, summary="Who the token belongs to")
def me(request: Request) -> Me:
    return Me(name=request.state.principal.name, role=request.state.principal.role)


@router.get("/clock", response_model=Clock, openapi_extra=READ,
            summary="The served sources' clock (the demo's simulated day, or the wall clock)")
def clock(request: Request) -> dict:
    return request.app.state.clock.as_dict()


# ---- the twin ---------------------------------------------------------------------------------------------
@router.get("/elements", response_model=list[Element], openapi_extra=READ, responses=UNAVAILABLE,
            summary="Every element with its status and deviation")
async def elements(request: Request) -> list[dict]:
    return await run_in_threadpool(_twin(request).elements)


@router.get("/elements/{global_id}", response_model=ElementDetail, openapi_extra=READ,
            responses={404: {"description": "No such element."}, **UNAVAILABLE},
            summary="One element's status, deviation and history")
async def element(request: Request, global_id: str = GLOBAL_ID) -> dict:
    found = await run_in_threadpool(_twin(request).element, global_id)
    if found is None:
        raise HTTPException(404, "no such element")
    return found


@router.get("/state", response_model=TwinState, openapi_extra=READ, responses=UNAVAILABLE,
            summary="The twin's state now, or as it was at a past time")
async def state(request: Request, at: float | None = Query(None, ge=0, le=1e11, description="UTC epoch seconds.")
                ) -> dict:
    view = _twin(request)
    records = await run_in_threadpool(view.elements, at)
    counts: dict[str, int] = {}
    for record in records:
        counts[record["status"]] = counts.get(record["status"], 0) + 1
    span = await run_in_threadpool(view.span)
    return {"at": at, "counts": counts, "span": list(span) if span else None, "elements": records}


@router.get("/observations", response_model=list[TwinRecord], openapi_extra=READ, responses=UNAVAILABLE,
            summary="The robots' observation and missing records")
async def observations(request: Request, after: int = Query(0, ge=0, le=2**62, description="Records after seq."),
                       limit: int = Query(500, ge=1, le=5000)) -> list[dict]:
    return await run_in_threadpool(_twin(request).observations, after, limit)


@router.get("/plan", openapi_extra=READ, responses=UNAVAILABLE,
            summary="The site plan: structure, zones, elements by status and the robot's path (world metres)")
async def plan(request: Request, at: float | None = Query(None, ge=0, le=1e11, description="UTC epoch seconds: "
                                                         "the plan as the twin was then.")) -> dict:
    return await run_in_threadpool(_twin(request).plan, at)


@router.get("/progress", openapi_extra=READ, responses=UNAVAILABLE,
            summary="Progress against the model's work schedule: each task's planned %, observed % and status, the "
                    "S-curve, the structure built / not built")
async def progress(request: Request, at: float | None = Query(None, ge=0, le=1e11, description="UTC epoch seconds: "
                                                              "the progress as the twin was then.")) -> dict:
    return await run_in_threadpool(_twin(request).progress, at)


@router.get("/model.glb", openapi_extra=READ, response_class=Response, summary="The twin in 3-D (binary glTF)",
            responses={200: {"content": {"model/gltf-binary": {}}}, **UNAVAILABLE})
async def model_glb(request: Request) -> Response:
    data = await run_in_threadpool(_twin(request).model_glb)
    return Response(data, media_type="model/gltf-binary", headers={"Cache-Control": "no-store"})


@router.get("/exports/twin.bcf", openapi_extra=READ, response_class=Response,
            summary="BCF 2.1 issues: one topic per deviating, missing or new element",
            responses={200: {"content": {"application/octet-stream": {}}}, **UNAVAILABLE})
async def export_bcf(request: Request) -> Response:
    return await _download(request, "bcf")


@router.get("/exports/twin.ifc", openapi_extra=READ, response_class=Response,
            summary="The BIM with the twin written back (IFC4/IFC4X3)",
            responses={200: {"content": {"application/x-step": {}}},
                       409: {"description": "The model's schema cannot be written back (IFC2X3)."}, **UNAVAILABLE})
async def export_ifc(request: Request) -> Response:
    return await _download(request, "ifc")


# ---- exposure ---------------------------------------------------------------------------------------------
@router.get("/workers", response_model=list[Worker], openapi_extra=READ, responses=UNAVAILABLE,
            summary="Each worker's A(8), points and time to EAV/ELV today, under pseudonyms, with live activity")
async def workers(request: Request) -> list[dict]:
    return await run_in_threadpool(_safety(request).workers)


@router.get("/workers/{subject}", response_model=Worker, openapi_extra=READ,
            responses={404: {"description": "No such worker today."}, **UNAVAILABLE}, summary="One worker's day")
async def worker(request: Request, subject: str = SUBJECT) -> dict:
    found = await run_in_threadpool(_safety(request).worker, subject)
    if found is None:
        raise HTTPException(404, "no such worker")
    return found


@router.get("/devices/refused", response_model=list[RefusedMessages], openapi_extra=READ, responses=UNAVAILABLE,
            summary="Messages the HAV monitor refused, per device (malformed, wrong device id): never exposure")
async def refused_messages(request: Request) -> list[dict]:
    return await run_in_threadpool(_safety(request).refused)


@router.get("/events", response_model=list[SafetyEvent], openapi_extra=READ, responses=UNAVAILABLE,
            summary="The HAV monitor's safety events in event-time order, oldest first")
async def events(request: Request, since: float | None = Query(None, ge=0, le=1e11, description="UTC epoch s."),
                 kind: str | None = Query(None, max_length=64),
                 limit: int = Query(1000, ge=1, le=10000)) -> list[dict]:
    return await run_in_threadpool(_safety(request).events, since, kind, limit)


@router.post("/workers/{subject}/identity", response_model=Identity, openapi_extra=REVEAL_IDENTITY,
             responses={404: {"description": "No identity on record for this pseudonym (audited)."}, **AUDITED},
             summary="Who is behind a pseudonym (safety officer only; audited)")
async def reveal_identity(request: Request, body: RevealRequest, subject: str = SUBJECT) -> Identity:
    view = _safety(request)
    worker_id = await run_in_threadpool(view.real_name, subject)
    if worker_id is None:
        await write_audit(request, "identity", subject, body.reason, {}, "refused: not found")
        raise HTTPException(404, "no identity on record for this pseudonym")
    await write_audit(request, "identity", subject, body.reason, {})
    return Identity(subject=subject, worker=worker_id)


@router.post("/workers/{subject}/raw", response_model=RawWindows, openapi_extra=REVEAL_RAW,
             responses={404: {"description": "No such worker (audited)."}, **AUDITED},
             summary="A raw sensor window of a worker's devices (safety officer only; audited)")
async def reveal_raw(request: Request, body: RawRequest, subject: str = SUBJECT) -> dict:
    """The window is cut to the server's limit (``raw_window_max_s``); ``seconds`` in the answer is what was
    served."""
    view = _safety(request)
    seconds = min(body.seconds, request.app.state.config.raw_window_max_s)
    if subject not in await run_in_threadpool(view.subjects):
        await write_audit(request, "raw", subject, body.reason, {"start": body.start, "seconds": seconds},
                    "refused: not found")
        raise HTTPException(404, "no such worker")
    await write_audit(request, "raw", subject, body.reason, {"start": body.start, "seconds": seconds})
    windows = await run_in_threadpool(view.raw_window, subject, body.start, seconds)
    return {"subject": subject, "seconds": seconds, "windows": windows}


@router.get("/audit", response_model=list[AuditEntry], openapi_extra=ADMIN_ONLY,
            summary="The audit log of identity and raw-data reveals and refused attempts (admin only)")
async def audit(request: Request) -> list[dict]:
    return await run_in_threadpool(request.app.state.audit.entries)


# ---- helpers ----------------------------------------------------------------------------------------------
def _twin(request: Request):
    view = request.app.state.twin
    if view is None:
        raise HTTPException(503, "this server has no twin")
    return view


def _safety(request: Request):
    view = request.app.state.safety
    if view is None:
        raise HTTPException(503, "this server has no HAV monitor")
    return view


async def _download(request: Request, kind: str) -> Response:
    from bim2rdt.twin import TwinError

    try:
        data = await run_in_threadpool(_twin(request).export, kind)
    except TwinError as error:
        raise HTTPException(409, str(error)) from None
    media = "application/octet-stream" if kind == "bcf" else "application/x-step"
    return Response(data, media_type=media, headers={"Content-Disposition": f'attachment; filename="twin.{kind}"'})
