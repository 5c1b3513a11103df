"""The API's documented shapes (OpenAPI at /openapi.json): what each endpoint returns and accepts."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field


class Health(BaseModel):
    status: str = Field(description="'ok' while the server answers.")
    version: str
    twin: bool = Field(description="A digital twin is served.")
    monitor: bool = Field(description="A HAV monitor is served.")
    stream_clients: int = Field(description="Clients on the live stream now.")


class Clock(BaseModel):
    now: float = Field(description="UTC epoch seconds of the served sources now (a demo's simulated day).")
    speed: float = Field(description="Source seconds per wall second (1: the wall clock).")
    simulated: bool = Field(description="The sources run on a simulated clock, not the wall clock.")


class Me(BaseModel):
    name: str
    role: str


class Element(BaseModel):
    """One element as the twin knows it (units: metres, degrees, UTC epoch seconds; pose 4x4 T_world_model)."""

    model_config = ConfigDict(extra="allow")
    global_id: str
    name: str | None = None
    family: str | None = None
    ifc_class: str | None = Field(None, description="None for an object the BIM lacks.")
    status: str = Field(description="not observed, as planned, deviating, missing, new or unverified.")
    colour: str = Field(description="The status colour, #rrggbb.")
    deviation: dict[str, Any] | None = Field(None, description="translation (m), tilt_deg, yaw_deg against the BIM.")
    tolerance: dict[str, Any] | None = None
    fit: dict[str, Any] | None = None
    evidence: dict[str, Any] | None = None
    robot: str | None = None
    pose: list[list[float]] | None = None


class TwinRecord(BaseModel):
    """One entry of the twin's append-only history."""

    seq: int
    kind: str = Field(description="observation, missing, status or safety.")
    time: float
    global_id: str | None = None
    source: str
    data: dict[str, Any]
    recorded: float


class ElementDetail(Element):
    history: list[TwinRecord]


class TwinState(BaseModel):
    at: float | None = Field(description="The time the state is of (UTC s); None: now.")
    counts: dict[str, int]
    span: list[float] | None = Field(description="[first, last] time of the twin's records (UTC s).")
    elements: list[Element]


class Device(BaseModel):
    device: str
    tool: str
    position: str
    zone: str | None = None
    hand: str = ""
    estimate: bool = Field(description="Not measured at the ISO position: the exposure is an estimate.")
    active: bool = Field(description="A tool is running on this device now.")
    a_hv: float | None = Field(description="The running activity's vibration total value, m/s^2 (0 when idle).")
    activity_started: float | None = None
    counters: dict[str, float] = Field(description="Stream counters: duplicates, late, gaps, malformed (messages "
                                       "refused from this device), restarts, ...")


class Worker(BaseModel):
    """One worker's day under their pseudonym (ISO 5349-1: A(8) in m/s^2, HSE points)."""

    subject: str = Field(description="The pseudonym, w- + 16 hex digits.")
    a8: float | None
    points: float | None
    risk: str = Field(description="below_eav, above_eav or above_elv.")
    eav: float
    elv: float
    eav_at: float | None = None
    elv_at: float | None = None
    exposure_s: float | None = Field(description="Trigger time counted today, seconds.")
    active: bool
    a_hv: float | None
    seconds_to_eav: float | None = Field(description="Tool-on seconds until the EAV at the running a_hv; 0 when "
                                         "reached; None when idle.")
    seconds_to_elv: float | None
    devices: list[Device]
    days: list[str] | None = None


class RefusedMessages(BaseModel):
    """A device's messages the monitor refused (malformed, a device id not the topic's, too slowly sampled):
    counted, never exposure. A device that sends only garbage shows here and nowhere else."""

    device: str
    count: int = Field(description="Messages refused since the monitor's store began.")
    last_reason: str = Field(description="Why the last one was refused.")
    last_received: float | None = Field(description="When the last one arrived (UTC s, the monitor's clock).")
    subject: str | None = Field(description="The pseudonym of who wears the device; None: no worker on it.")


class SafetyEvent(BaseModel):
    kind: str = Field(description="hav.activity_started, hav.eav_predicted, hav.eav_reached, hav.elv_reached, "
                      "hav.activity_ended, hav.gap, hav.artefact, ...")
    time: float
    subject: str
    source: str
    data: dict[str, Any]
    received: float | None = None


class RevealRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    reason: str = Field(min_length=3, max_length=500, description="Why the identity is needed (audited).")


class RawRequest(RevealRequest):
    start: float | None = Field(None, ge=0, le=1e11, allow_inf_nan=False, description="Device time of the window's start (UTC s); "
                                "None: the newest samples kept.")
    seconds: float = Field(2.0, gt=0, le=600, allow_inf_nan=False, description="Window length, seconds (cut to the server's limit, "
                           "10 s by default).")


class Identity(BaseModel):
    subject: str
    worker: str


class RawWindow(BaseModel):
    device: str
    tool: str
    fs: float | None = Field(description="Sampling rate, Hz (None: nothing kept in the window).")
    start: float
    samples: list[list[float]] = Field(description="(n, 3) acceleration, m/s^2, device axes.")


class RawWindows(BaseModel):
    subject: str
    seconds: float = Field(description="The window length served (the request's, cut to the server's limit).")
    windows: list[RawWindow]


class AuditEntry(BaseModel):
    """One reveal or reveal attempt; a line of the log that is not a whole record (a write cut short) is an entry
    with action and outcome 'damaged', ``at`` None and ``detail`` {line, bytes, text}."""

    at: float | None = Field(description="UTC epoch seconds; None for a damaged line.")
    who: str
    role: str
    action: str = Field(description="identity, raw or damaged.")
    subject: str
    why: str
    outcome: str = Field("revealed", description="revealed, refused: role (403), refused: not found (404), "
                         "refused: rate (429) or damaged.")
    detail: dict[str, Any]
