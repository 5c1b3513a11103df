"""What the API reads from the HAV monitor: each worker's day under their pseudonym, live activity, events, and
(for the safety role only) the identity behind a pseudonym and raw sensor windows.

Everything comes from the monitor's read side (``monitor.queries``, :class:`~bim2rdt.safety.queries.MonitorQueries`):
exposure figures from its in-memory reads (``devices``, ``session``, ``activity``, ``day``, ``stream_status``), which
hold the monitor's lock; events and raw windows from its store reads (``queries.reads``: the store's pooled
connections, never the monitor's lock nor its file opened here).
"""

from __future__ import annotations

import math
import threading

import numpy as np

from bim2rdt.safety import EAV, ELV, T0_S
from bim2rdt.server.hub import event_record

E_EAV, E_ELV = EAV**2 * T0_S, ELV**2 * T0_S
"""Daily weighted energy (m^2/s^3) at which A(8) reaches the EAV and the ELV."""


def seconds_to(limit_energy: float, energy: float, a_hv: float) -> float | None:
    """Tool-on seconds until the day's energy reaches ``limit_energy`` at the running a_hv (m/s^2): 0 when
    already there, None when no tool is running (the time is not defined while the worker is idle)."""
    if energy >= limit_energy:
        return 0.0
    if a_hv <= 0:
        return None
    return (limit_energy - energy) / a_hv**2


class SafetyView:
    """Reads one HavMonitor's read side (``monitor.queries``) for the API; ``identity`` is an ``IdentityMap``
    opened with role 'safety' (None: identities cannot be revealed on this server)."""

    def __init__(self, queries, identity=None):
        self.queries, self.identity = queries, identity
        self._reader = queries.reads
        self._lock = threading.Lock()

    def close(self) -> None:
        """Nothing to release: the reads use the monitor's store, which the monitor closes."""

    # ---- exposure ---------------------------------------------------------------------------------------
    def workers(self) -> list[dict]:
        """Every worker on a device today: A(8), points, risk, time to EAV/ELV and what each device does now."""
        by_subject: dict[str, list[dict]] = {}
        refused = self.queries.malformed_messages()
        for device in sorted(self.queries.devices()):
            session = self.queries.session(device)
            if session is not None:
                by_subject.setdefault(session.subject, []).append(self._device(device, session, refused))
        return [self._worker(subject, devices) for subject, devices in sorted(by_subject.items())]

    def worker(self, subject: str) -> dict | None:
        found = next((w for w in self.workers() if w["subject"] == subject), None)
        if found is not None:
            found["days"] = self.queries.days_of(subject)
        return found

    def refused(self) -> list[dict]:
        """Per device, the messages the monitor refused (dead-lettered), most first; with the wearer's pseudonym
        where the device has a session (a device sending only garbage has none)."""
        rows = []
        for device, refused in self.queries.malformed_messages().items():
            session = self.queries.session(device)
            rows.append({"device": device, "count": refused.count, "last_reason": refused.last_reason,
                         "last_received": refused.last_received, "subject": session.subject if session else None})
        return sorted(rows, key=lambda row: (-row["count"], row["device"]))

    def subjects(self) -> set[str]:
        return {w["subject"] for w in self.workers()}

    def events(self, since: float | None = None, kind: str | None = None, limit: int = 1000) -> list[dict]:
        """The monitor's events after ``since`` (UTC s, device time) in event-time order, oldest first (the store
        keeps commit order: a device's late batch commits after another's newer events), the newest ``limit``."""
        with self._lock:
            events = self._reader.events(kind, since)
        chosen = sorted((event_record(e) for e in events), key=lambda record: record["time"])
        return chosen[-limit:]

    # ---- safety role only -------------------------------------------------------------------------------
    def real_name(self, subject: str) -> str | None:
        """The worker id behind a pseudonym (the identity map enforces the safety role itself)."""
        if self.identity is None:
            return None
        with self._lock:
            return self.identity.real_name(subject)

    def raw_window(self, subject: str, start: float | None, seconds: float) -> list[dict]:
        """The raw samples (m/s^2, per axis) of every device the worker wears, in device time [start,
        start + seconds); ``start`` None means the last ``seconds`` of each device's stored data."""
        windows = []
        for device in sorted(self.queries.devices()):
            session = self.queries.session(device)
            if session is None or session.subject != subject:
                continue
            with self._lock:
                begin = start if start is not None else self._last_time(device) - seconds
                batches = self._reader.raw_window(device, begin, begin + seconds)
            windows.append(_window(device, session, batches, begin, seconds))
        return windows

    # ---- helpers ----------------------------------------------------------------------------------------
    def _device(self, device: str, session, refused: dict) -> dict:
        activity = self.queries.activity(device)
        running = activity is not None and activity.id is not None
        status = self.queries.stream_status(device) or {}
        counters = {k: v for k, v in status.items() if isinstance(v, int | float) and not isinstance(v, bool)
                    and k not in ("next_seq", "clock_offset_s")}
        counters["malformed"] = refused[device].count if device in refused else 0
        return {"device": device, "tool": session.tool, "position": session.position, "zone": session.zone,
                "hand": session.hand, "estimate": session.estimate, "active": running,
                "a_hv": _finite(activity.a_hv) if running else 0.0,
                "activity_started": activity.started if running else None, "counters": counters}

    def _worker(self, subject: str, devices: list[dict]) -> dict:
        day = self.queries.day(subject)
        a_hv = max((d["a_hv"] for d in devices if d["active"]), default=0.0)
        return {"subject": subject, "a8": _finite(day.a8), "points": _finite(day.points), "risk": day.risk,
                "eav": EAV, "elv": ELV, "eav_at": day.eav_at, "elv_at": day.elv_at,
                "exposure_s": _finite(day.seconds), "active": any(d["active"] for d in devices), "a_hv": a_hv,
                "seconds_to_eav": seconds_to(E_EAV, day.energy, a_hv),
                "seconds_to_elv": seconds_to(E_ELV, day.energy, a_hv), "devices": devices}

    def _last_time(self, device: str) -> float:
        """The device time just after its newest kept raw sample (0 when none is kept)."""
        last = self._reader.last_sample_time(device)
        return last if last is not None else 0.0


def _window(device: str, session, batches, start: float, seconds: float) -> dict:
    """One device's samples cut to [start, start + seconds)."""
    if not batches:
        return {"device": device, "tool": session.tool, "fs": None, "start": start, "samples": []}
    fs = batches[0].fs
    times = np.concatenate([b.device_time + np.arange(b.xyz.shape[0]) / b.fs for b in batches])
    xyz = np.concatenate([b.xyz for b in batches])
    keep = (times >= start) & (times < start + seconds)
    first = float(times[keep][0]) if keep.any() else start
    return {"device": device, "tool": session.tool, "fs": fs, "start": first,
            "samples": np.round(xyz[keep].astype(float), 4).tolist()}


def _finite(value: float) -> float | None:
    return float(value) if value is not None and math.isfinite(value) else None
