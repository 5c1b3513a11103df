"""What the API reads from the digital twin: element states, histories, the plan, the 3-D model and exports.

The twin (``bim2rdt.twin.DigitalTwin``) keeps an in-memory projection that reads catch up on; the view holds
one lock around every call, so the server's worker threads and the live poller never interleave inside it.
"""

from __future__ import annotations

import tempfile
import threading
from pathlib import Path

import numpy as np

from bim2rdt.server.plan import FLOORS, STRUCTURE, ZONES, bounds, hull_xy, posed, robot_path
from bim2rdt.twin import MISSING, OBSERVATION, SAFETY, STATUS, STATUS_COLOURS, ElementState, ElementStatus
from bim2rdt.twin import recorded_outbox_ids

CHANGE_KINDS = (OBSERVATION, MISSING, STATUS)
"""Twin records the live stream forwards (safety events reach it straight from the monitor)."""


def palette() -> dict[str, str]:
    """{status value: '#rrggbb'}: the twin's one palette (``STATUS_COLOURS``) as CSS colours."""
    from matplotlib.colors import to_hex

    return {status.value: to_hex(colour) for status, colour in STATUS_COLOURS.items()}


class TwinView:
    """Reads one DigitalTwin for the API; ``seq`` is the newest record the live poller has passed on."""

    def __init__(self, twin):
        self.twin = twin
        self.model = twin.model
        self._lock = threading.Lock()
        self._model_ifc = None
        self._colours = palette()
        self._elements = {el.global_id: el for el in self.model.elements}
        self._glb: tuple[int, bytes] | None = None
        self.seq = max((e.seq for e in twin.events()), default=0)

    # ---- elements ---------------------------------------------------------------------------------------
    def elements(self, at: float | None = None) -> list[dict]:
        """Every element's state (status, deviation, tolerance, fit, evidence, pose, colour), now or at ``at``."""
        with self._lock:
            states = self.twin.state(at)
        return [self._record(state) for state in states.values() if state.ifc_class not in ZONES]

    def element(self, global_id: str) -> dict | None:
        """One element's present state and its whole history (None for a GlobalId the twin does not know)."""
        with self._lock:
            state = self.twin.state().get(global_id)
            if state is None:
                return None
            history = self.twin.history(global_id)
        return {**self._record(state), "history": [event_dict(e) for e in history]}

    def observations(self, after: int = 0, limit: int = 500) -> list[dict]:
        """Observation and missing records after seq ``after``, in store order, at most ``limit``."""
        with self._lock:
            events = self.twin.events(after=after, kinds=[OBSERVATION, MISSING])
        return [event_dict(e) for e in events[:limit]]

    def span(self) -> tuple[float, float] | None:
        """(first, last) time of the twin's records (UTC s), None while it has none."""
        with self._lock:
            times = [e.time for e in self.twin.events(kinds=[OBSERVATION, MISSING, SAFETY])]
        return (min(times), max(times)) if times else None

    # ---- live changes -----------------------------------------------------------------------------------
    def changes(self) -> list[tuple[dict, dict | None]]:
        """Records appended since the last call (by any robot), each with the present state of its element."""
        with self._lock:
            events = self.twin.events(after=self.seq)
            if not events:
                return []
            self.seq = events[-1].seq
            wanted = [e for e in events if e.kind in CHANGE_KINDS]
            states = self.twin.state() if wanted else {}
        return [(event_dict(e), self._record(states[e.global_id]) if e.global_id in states else None)
                for e in wanted]

    def safety_sink(self):
        """A durable monitor sink (the monitor queues events in its store and delivers them from its own thread,
        retrying while the twin is locked) that appends safety events to the twin's history under this view's
        lock (a group of events in one transaction)."""
        view = self

        class LockedTwinSink:
            outbox = "twin"

            def emit(self, event) -> None:
                self.emit_many([event])

            def emit_many(self, events) -> None:
                with view._lock:
                    view.twin.record_events(events)

            def delivered(self, events) -> set[int]:
                with view._lock:
                    return recorded_outbox_ids(view.twin, events)

        return LockedTwinSink()

    # ---- plan and 3-D -----------------------------------------------------------------------------------
    def plan(self, at: float | None = None) -> dict:
        """Structure, floors and zones from the BIM; elements by status (where the robot found them, and where the
        BIM has them); the robot's path from the twin's evidence; bounds and the palette. Now, or as the twin was
        at time ``at``."""
        with self._lock:
            states = self.twin.state(at)
            path = robot_path(e for e in self.twin.events(kinds=[OBSERVATION, MISSING]) if at is None or e.time <= at)
            structure, floors, zones, elements = [], [], [], []
            for el in self.model.elements:
                if el.ifc_class in ZONES or not self.model.has_mesh(el.global_id):
                    continue
                state = states.get(el.global_id)
                observed = state is not None and state.status is not ElementStatus.NOT_OBSERVED
                if el.ifc_class in FLOORS:
                    floors.append(self._outline(el.global_id, el.ifc_class, el.name))
                elif el.ifc_class in STRUCTURE and not observed:
                    structure.append(self._outline(el.global_id, el.ifc_class, el.name))
            zones = [self._zone(zone) for zone in self.model.zones]
            for state in states.values():
                if state.ifc_class in FLOORS | ZONES or (state.ifc_class in STRUCTURE
                                                         and state.status is ElementStatus.NOT_OBSERVED):
                    continue
                elements.append(self._element_outline(state))
        drawn = [o["outline"] for o in structure + floors + elements if o["outline"]]
        return {"at": at, "bounds": bounds(drawn + [[[p["x"], p["y"]]] for p in path]), "palette": self._colours,
                "floors": floors, "structure": structure, "zones": [z for z in zones if z is not None],
                "elements": elements, "robot_path": path}

    def model_glb(self) -> bytes:
        """The twin in 3-D as binary glTF: one node per element (named by GlobalId), world coordinates, z up;
        elements at their measured pose where the robot found them. Rebuilt only when the twin changed."""
        with self._lock:
            if self._glb is not None and self._glb[0] == self.seq:
                return self._glb[1]
            data = self._build_glb(self.twin.state())
            self._glb = (self.seq, data)
            return data

    # ---- progress ---------------------------------------------------------------------------------------
    def progress(self, at: float | None = None) -> dict:
        """Progress against the model's work schedule (``twin.progress_record``: the tasks, the S-curve, the
        structure built / not built), now or as the twin was at time ``at``; the IFC file is parsed once."""
        from bim2rdt.twin import open_model_ifc, progress_record

        with self._lock:
            if self._model_ifc is None:
                self._model_ifc = open_model_ifc(self.twin)
            return progress_record(self.twin, self._model_ifc, at)

    # ---- exports ----------------------------------------------------------------------------------------
    def export(self, kind: str) -> bytes:
        """``bcf`` or ``ifc`` (the twin's own exports), as bytes; TwinError when the model cannot be written."""
        with tempfile.TemporaryDirectory(prefix="bim2rdt-export-") as folder, self._lock:
            path = Path(folder) / f"twin.{kind}"
            (self.twin.export_bcf if kind == "bcf" else self.twin.export_ifc)(path)
            return path.read_bytes()

    # ---- helpers ----------------------------------------------------------------------------------------
    def _record(self, state: ElementState) -> dict:
        return {**state.to_dict(), "name": self._name(state.global_id), "colour": self._colours[state.status.value]}

    def _name(self, global_id: str) -> str | None:
        element = self._elements.get(global_id)  # None for an object the BIM lacks
        return element.name if element else None

    def _outline(self, global_id: str, ifc_class: str, name: str | None) -> dict:
        vertices, _ = self.model.mesh(global_id)
        return {"global_id": global_id, "ifc_class": ifc_class, "name": name, "outline": hull_xy(vertices)}

    def _zone(self, zone) -> dict | None:
        if not self.model.has_mesh(zone.global_id):
            return None
        vertices, _ = self.model.mesh(zone.global_id)
        return {"global_id": zone.global_id, "name": zone.name, "off_limits": bool(zone.off_limits),
                "kind": zone.kind, "outline": hull_xy(vertices)}

    def _element_outline(self, state: ElementState) -> dict:
        body, _ = self.twin.object_mesh(state)
        planned = None
        if state.in_bim:
            planned = hull_xy(posed(body, self._elements[state.global_id].placement))
        found = hull_xy(posed(body, state.pose)) if state.pose is not None else planned
        return {"global_id": state.global_id, "family": state.family, "ifc_class": state.ifc_class,
                "status": state.status.value, "colour": self._colours[state.status.value], "outline": found,
                "planned": planned}

    def _build_glb(self, states: dict[str, ElementState]) -> bytes:
        import trimesh

        scene = trimesh.Scene()
        for state in states.values():
            if state.ifc_class in ZONES:
                continue
            if state.pose is not None:
                body, faces = self.twin.object_mesh(state)
                vertices = posed(body, state.pose)
            elif state.in_bim and self.model.has_mesh(state.global_id):
                vertices, faces = self.model.mesh(state.global_id)
            else:
                continue
            if len(faces) == 0:
                continue
            mesh = trimesh.Trimesh(np.asarray(vertices, dtype=np.float32), np.asarray(faces), process=False)
            scene.add_geometry(mesh, node_name=state.global_id, geom_name=state.global_id)
        return scene.export(file_type="glb")


def event_dict(event) -> dict:
    """A twin history record as JSON-ready data."""
    return {"seq": event.seq, "kind": event.kind, "time": event.time, "global_id": event.global_id,
            "source": event.source, "data": event.data, "recorded": event.recorded}


__all__ = ["CHANGE_KINDS", "TwinView", "event_dict", "palette"]
