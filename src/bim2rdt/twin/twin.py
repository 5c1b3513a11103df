"""``DigitalTwin``: the site as the robots found it, over the BIM, with its whole history.

```python
twin = DigitalTwin.open("sqlite:///out/twin.db", model)   # or postgresql+psycopg://user:password@host/db
twin.record(observation, time)        # a perception Observation; judged against the BIM and appended
                                      # (rmse inf with fitness 0, a fit with no inlier: unverified, rmse None)
twin.mark_missing(global_id, time)    # its place was seen empty
twin.record_structure(global_id, status, time, pose=..., deviation=...)   # a wall's or slab's judgement
twin.record_event(event)              # a safety event (bus.Event) of the HAV monitor
twin.record_events(events)            # several (one monitor commit's) in one transaction
twin.state(at=None)                   # {global_id: ElementState}: the present, or as it was at time `at`
twin.history(global_id)               # every recorded change of one element, oldest first
twin.events(since=None, after=0)      # the history as a feed (``after`` a seq: for pollers)
twin.export_ifc(path); twin.export_json(path); twin.export_bcf(path)
```

Nothing is ever updated in place: the store is an append-only event log, and the state is a fold of it (see
``projection``). Each write happens in one transaction under the writers' lock, after catching up on what other
robots appended, so several processes can record into one twin and the status changes they log stay a chain.
Times are UTC epoch seconds on the site's clock; poses are 4x4 T_world_model in metres.
"""

from __future__ import annotations

import dataclasses
import json
import math
import numbers
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path

import ifcopenshell.guid
import numpy as np

from bim2rdt.atomic import write_bytes_atomic
from bim2rdt.bim import BimElement, BimModel, load_ifc
from bim2rdt.bus import Event
from bim2rdt.frames import rigid_problem
from bim2rdt.perception import Observation
from bim2rdt.twin.errors import TwinError
from bim2rdt.twin.projection import STATE_KINDS, Projection
from bim2rdt.twin.records import MISSING, OBSERVATION, SAFETY, STATUS, STRUCTURE, ElementState, TwinEvent
from bim2rdt.twin.status import ElementStatus
from bim2rdt.twin.store import EventStore, NewEvent, Writer
from bim2rdt.twin.config import TwinConfig
from bim2rdt.twin.deviation import Deviation
from bim2rdt.twin.text import checked_text
from bim2rdt.twin.tolerance import Tolerance, TolerancePolicy
from bim2rdt.twin.verdict import judge_observation

FamilyMesh = Callable[[str], tuple[np.ndarray, np.ndarray] | None]
"""family -> (vertices (N,3) in the body frame, metres; faces (M,3)): the mesh of an object the BIM lacks (None
when the family is unknown: a 0.5 m box stands in)."""
NEW_MATCH_RADIUS = 1.0
"""A new object seen within this distance (m, horizontal) of a known new object of its family is that object."""


class DigitalTwin:
    """The twin of one BIM model over one event store: an append-only history of observations, projected into
    each element's present state. Build it with :meth:`open`, which checks the arguments.

    Args:
        store: The event store (SQLite or PostgreSQL).
        model: The BIM the twin is of.
        tolerances: Picks each element's tolerance preset.
        symmetry: {family: rotational order about up} (``math.inf`` for axial; 1 where absent).
        min_fitness: Observations whose fitness (0-1) is under this are unverified.
        robot: The default source of records.
        family_mesh: The mesh of a family the BIM lacks, for exports; None uses a 0.5 m box.
        new_match_radius: A new object within this horizontal distance (metres) of a known new object of its
            family is that object.
    """

    def __init__(self, store: EventStore, model: BimModel, tolerances: TolerancePolicy,
                 symmetry: Mapping[str, float], min_fitness: float, robot: str, family_mesh: FamilyMesh | None,
                 new_match_radius: float):
        self.store, self.model, self.tolerances = store, model, tolerances
        self.symmetry, self.min_fitness, self.robot = dict(symmetry), min_fitness, robot
        self.family_mesh, self.new_match_radius = family_mesh, new_match_radius
        self._elements = {el.global_id: el for el in model.elements}
        self._projection = Projection(model).apply_all(store.read())

    @classmethod
    def open(cls, url: str, model: BimModel | str | Path, *, tolerances: TolerancePolicy | None = None,
             symmetry: Mapping[str, float] | None = None, min_fitness: float = 0.5, robot: str = "robot",
             family_mesh: FamilyMesh | None = None, new_match_radius: float = NEW_MATCH_RADIUS,
             create: bool = True, run: str | None = None, partial: bool = False) -> DigitalTwin:
        """Open the twin at ``url`` over ``model`` (a BimModel or an IFC path); with ``create`` (default) an empty
        store gets its table, without it a URL that holds no twin is a TwinError (for readers).

        ``tolerances`` picks each element's preset (default: ``TwinConfig()``'s presets); ``symmetry`` maps a
        family to its rotational order about up (``math.inf`` for axial; 1 where absent); observations under
        ``min_fitness`` are unverified; ``robot`` is the default source of records; ``family_mesh`` gives the
        mesh of objects the BIM lacks (exports; a 0.5 m box stands in without it). The edge builds these from
        ``Settings.twin`` (``TwinConfig.resolved_url``, ``.tolerance_policy()``, ``.min_fitness``).

        Args:
            url: SQLAlchemy URL of the event store (``sqlite:///...`` or ``postgresql+psycopg://...``).
            model: A loaded model, or the path of an IFC file to load.
            tolerances: Picks each element's preset; None uses ``TwinConfig()``'s presets.
            symmetry: {family: rotational order about up}; None means none is symmetric.
            min_fitness: Observations whose fitness (0-1) is under this are unverified.
            robot: The default source of records.
            family_mesh: The mesh of a family the BIM lacks, for exports; None uses a 0.5 m box.
            new_match_radius: Horizontal distance (metres) within which a new object is a known new one.
            create: Create the store's table when it is empty; False for readers.
            run: A run that builds this store whole (its source, e.g. "verify"): marked started now and
                unfinished until :meth:`finish_run`.
            partial: For readers (``create`` False): open a store a run did not finish (its state is partial)
                instead of refusing it.

        Returns:
            The twin, its projection caught up with the store.

        Raises:
            TwinError: A bad symmetry or ``min_fitness``; without ``create``, a URL that holds no twin, or (unless
                ``partial``) a store a run began and did not finish.
            BimError: The IFC file cannot be read.
        """
        _check_symmetry(symmetry or {})
        if not 0.0 <= min_fitness <= 1.0:
            raise TwinError(f"min_fitness is a fraction in [0, 1], got {min_fitness}")
        model = model if isinstance(model, BimModel) else load_ifc(model)
        store = EventStore.open(url, create, run)
        unfinished = [] if create or partial else store.unfinished_runs()
        if unfinished:
            store.close()
            source, started = unfinished[-1]
            raise TwinError(f"the twin at {store.label} is partial: the {source} run that began building it at "
                            f"{_utc(started)} did not finish (killed or failed); run it again")
        return cls(store, model, tolerances or TwinConfig().tolerance_policy(), symmetry or {},
                   min_fitness, robot, family_mesh, new_match_radius)

    def finish_run(self) -> None:
        """Mark the run :meth:`open` started (``run=``) as finished, after its last record: readers then take the
        store as whole."""
        self.store.finish_run()

    def unfinished_runs(self) -> list[tuple[str, float]]:
        """The runs that began building this store and did not finish.

        Returns:
            (source, started: UTC epoch seconds) of each, oldest first; empty for a whole store.
        """
        return self.store.unfinished_runs()

    def close(self) -> None:
        """Close the event store's connections."""
        self.store.close()

    def __enter__(self) -> DigitalTwin:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ---- recording (append-only) --------------------------------------------------------------------------

    def record(self, observation: Observation, time: float, *, robot: str | None = None,
               camera: np.ndarray | None = None) -> ElementState:
        """Judge ``observation`` against the BIM and append it (and a status event if the element's present
        status changes); returns the element's present state. ``camera`` is T_world_camera of the view it was
        seen best from (the BCF viewpoint). An observation without a GlobalId is an object the BIM lacks: it
        becomes a new object, or the known new one of its family within ``new_match_radius``.

        Args:
            observation: What perception made of the object: family, GlobalId (None for an object the BIM lacks),
                ``pose`` (``T_world_object``, 4x4, metres), fitness (0-1) and RMSE (metres).
            time: When it was seen, UTC seconds.
            robot: The record's source; None uses the twin's ``robot``.
            camera: ``T_world_camera`` (4x4) of the view it was seen best from; None records no viewpoint.

        Returns:
            The element's present state after the record.

        Raises:
            TwinError: A bad time, pose, fitness, RMSE or text, or a GlobalId the BIM does not have.
        """
        when = _checked_time(time)
        pose = _checked_pose(observation.pose, "the observation's pose")
        camera = None if camera is None else _checked_pose(camera, "the camera pose")
        no_inlier = math.isinf(observation.rmse) and observation.fitness == 0.0
        if not (0.0 <= observation.fitness <= 1.0 and (no_inlier or math.isfinite(observation.rmse))
                and observation.rmse >= 0):
            raise TwinError(f"an observation needs fitness in [0, 1] and a finite rmse >= 0 (inf only with fitness "
                            f"0: no inlier), got {observation.fitness} and {observation.rmse}")
        family = checked_text(observation.family, "family")
        reason = checked_text(getattr(observation, "reason", ""), "reason", may_be_empty=True)
        fit = _fit(observation)
        evidence = _evidence(observation.station, observation.frames, camera, observation.bbox)
        source = checked_text(robot or self.robot, "robot")

        def build(writer: Writer) -> list[TwinEvent]:
            if observation.global_id:
                global_id, element = observation.global_id, self._known(observation.global_id)
            else:
                global_id = self._match_new(family, pose) or ifcopenshell.guid.new()
                element = None
            tolerance = self.tolerances.for_element(element.ifc_class, element.family) if element else None
            status, deviation = judge_observation(pose, observation.fitness, element, tolerance,
                                                  self.symmetry.get(observation.family, 1), self.min_fitness)
            if no_inlier:
                status = ElementStatus.UNVERIFIED  # nothing of the view lies on the fitted model: nothing measured
            elif getattr(observation, "status", None) is ElementStatus.UNVERIFIED:
                status = ElementStatus.UNVERIFIED  # its observer could not judge it (a view blind along an axis)
            data = {"family": family, "status": status.value, "pose": pose.tolist(), "reason": reason,
                    "deviation": deviation.to_dict() if deviation else None,
                    "tolerance": tolerance.to_dict() if tolerance else None, "fit": fit, "evidence": evidence}
            return self._append_with_status(writer, NewEvent(OBSERVATION, when, global_id, source, data), status)

        appended = self._write(build)
        return self._projection.get(appended[0].global_id)

    def mark_missing(self, global_id: str, time: float, *, station: int | None = None,
                     frames: Iterable[int] = (), camera: np.ndarray | None = None,
                     robot: str | None = None) -> ElementState:
        """Record that the element's place was seen empty.

        Args:
            global_id: The element's GlobalId.
            time: When it was seen empty, UTC seconds.
            station: The index of the station it was looked at from.
            frames: The indices of the frames that saw the place.
            camera: ``T_world_camera`` (4x4) of the view; None records no viewpoint.
            robot: The record's source; None uses the twin's ``robot``.

        Returns:
            The element's present state (missing).

        Raises:
            TwinError: A bad time or pose, or a GlobalId the twin does not know.
        """
        when = _checked_time(time)
        camera = None if camera is None else _checked_pose(camera, "the camera pose")
        evidence = _evidence(station, tuple(frames), camera, None)
        source = checked_text(robot or self.robot, "robot")

        def build(writer: Writer) -> list[TwinEvent]:
            element = self._known(global_id)
            family = element.family if element else self._projection.get(global_id).family
            data = {"family": family, "status": ElementStatus.MISSING.value, "pose": None, "evidence": evidence}
            return self._append_with_status(writer, NewEvent(MISSING, when, global_id, source, data),
                                            ElementStatus.MISSING)

        return self._projection.get(self._write(build)[0].global_id)

    def record_structure(self, global_id: str, status: ElementStatus, time: float, *, pose: np.ndarray | None = None,
                         deviation: Deviation | None = None, tolerance: Tolerance | None = None,
                         frames: Iterable[int] = (), camera: np.ndarray | None = None, reason: str = "",
                         measured: Mapping | None = None, robot: str | None = None) -> ElementState:
        """Record a permanent element's judgement as the structure judge made it (:mod:`bim2rdt.structure`: from
        coverage and signed distances, against its own per-class tolerance), not judged again here.

        Args:
            global_id: The element's GlobalId (a BIM element).
            status: As planned, deviating or not built.
            time: When it was seen, UTC seconds.
            pose: Its measured placement (``T_world_model``, 4x4 metres: the BIM's moved by the measured offset);
                None for one not built.
            deviation: The measured offset and tilt against the BIM.
            tolerance: The tolerance it was judged by.
            frames: The indices of the frames that saw it.
            camera: ``T_world_camera`` (4x4) of a view that saw it; None records no viewpoint.
            reason: Why this status.
            measured: The judge's figures (coverage, median_mm, p95_mm, offset_m, rotation_deg), JSON-ready.
            robot: The record's source; None uses the twin's ``robot``.

        Returns:
            The element's present state.

        Raises:
            TwinError: A bad time or pose, a status the judge does not give, a deviating element without a pose,
                or a GlobalId the BIM does not have.
        """
        if status not in (ElementStatus.AS_PLANNED, ElementStatus.DEVIATING, ElementStatus.NOT_BUILT):
            raise TwinError(f"a structure judgement is as planned, deviating or not built, got {status.value}")
        when = _checked_time(time)
        pose = None if pose is None else _checked_pose(pose, "the element's measured pose")
        if status is ElementStatus.DEVIATING and pose is None:
            raise TwinError("a deviating element needs its measured pose")
        camera = None if camera is None else _checked_pose(camera, "the camera pose")
        evidence = _evidence(None, tuple(frames), camera, None)
        source = checked_text(robot or self.robot, "robot")
        reason = checked_text(reason, "reason", may_be_empty=True)

        def build(writer: Writer) -> list[TwinEvent]:
            element = self._elements.get(global_id)
            if element is None:
                raise TwinError(f"{self.model.path.name} has no element with GlobalId {global_id}")
            data = {"family": element.family, "status": status.value,
                    "pose": None if pose is None else pose.tolist(), "reason": reason,
                    "deviation": deviation.to_dict() if deviation else None,
                    "tolerance": tolerance.to_dict() if tolerance else None, "fit": None, "evidence": evidence,
                    "structure": json.loads(json.dumps(dict(measured or {})))}
            return self._append_with_status(writer, NewEvent(STRUCTURE, when, global_id, source, data), status)

        return self._projection.get(self._write(build)[0].global_id)

    def record_event(self, event: Event) -> TwinEvent:
        """Append a safety event of the HAV monitor; it joins the history of the work zone (or element) its
        ``data["zone"]`` names, if the BIM has it.

        Args:
            event: A bus event from the HAV monitor.

        Returns:
            The stored event.

        Raises:
            TwinError: A bad time or source name.
        """
        return self.record_events([event])[0]

    def record_events(self, events: Iterable[Event]) -> list[TwinEvent]:
        """Append safety events (as :meth:`record_event`) in one transaction, in order: the events of one monitor
        commit cost one synced write, and they are recorded all together or, on any error, none of them.

        Args:
            events: Bus events from the HAV monitor.

        Returns:
            The stored events, in order.

        Raises:
            TwinError: An event with a bad time or source name (then none is stored).
        """
        new = [self._safety_event(event) for event in events]
        return self._write(lambda writer: writer.append_all(new)) if new else []

    # ---- reading ------------------------------------------------------------------------------------------

    def state(self, at: float | None = None) -> dict[str, ElementState]:
        """{global_id: ElementState} of every BIM element and every object the BIM lacks: the present (all that
        any robot recorded so far), or, with ``at``, as it was at that time (a replay of the history).

        Args:
            at: A time, UTC seconds; None gives the present.

        Returns:
            {GlobalId: ElementState}.

        Raises:
            TwinError: A bad time.
        """
        if at is None:
            self._catch_up()
            return self._with_meshes(self._projection.states())
        replay = Projection(self.model).apply_all(self.store.read(until=_checked_time(at), kinds=STATE_KINDS,
                                                                  by_time=True))
        return self._with_meshes(replay.states())

    def history(self, global_id: str) -> list[TwinEvent]:
        """Every event about one element (observations, missing, status changes, safety events in its zone),
        oldest first (by the time it happened, then store order).

        Args:
            global_id: The element's GlobalId.

        Returns:
            Its events, oldest first.

        Raises:
            TwinError: The twin does not know the GlobalId.
        """
        self._catch_up()
        self._known(global_id)
        return self.store.read(global_id=global_id, by_time=True)

    def events(self, since: float | None = None, *, after: int = 0,
               kinds: Iterable[str] | None = None) -> list[TwinEvent]:
        """The history in store order: events that happened after ``since`` (UTC s) and/or were stored after
        seq ``after`` (a poller passes the last seq it saw), of ``kinds`` (default all).

        Args:
            since: Only events that happened after this time, UTC seconds; None for all.
            after: Only events stored after this sequence number.
            kinds: Only events of these kinds; None for all.

        Returns:
            The events, in store order.
        """
        return self.store.read(after=after, since=since, kinds=kinds)

    # ---- exports ------------------------------------------------------------------------------------------

    def export_json(self, path: str | Path) -> Path:
        """Write the present state as JSON (every element with status, deviation, tolerance, fit and evidence).

        Args:
            path: The output .json file, written atomically.

        Returns:
            The written path.

        Raises:
            WriteError: The file cannot be written.
        """
        states = self.state()
        counts = {status.value: 0 for status in ElementStatus}
        for state in states.values():
            counts[state.status.value] += 1
        record = {"model": self.model.path.name, "schema": self.model.schema, "digest": self.model.digest,
                  "store": self.store.label, "events": self._projection.last_seq,
                  "tolerances": {name: t.to_dict() for name, t in self.tolerances.presets.items()},
                  "counts": counts, "elements": [s.to_dict() for s in states.values()]}
        return write_bytes_atomic(Path(path), json.dumps(record, indent=1).encode("utf-8"))

    def export_ifc(self, path: str | Path) -> Path:
        """The BIM with the twin written back (IFC4/IFC4X3): deviating elements moved to their measured pose,
        new objects added as proxies, a ``BIM2RDT_Observation`` pset on every observed element, and the safety
        events as IfcEvent/IfcTask. An IFC2X3 model cannot be written back (TwinError says so); its twin lives
        in the history, the JSON and the BCF.

        Args:
            path: The output .ifc file, written atomically.

        Returns:
            The written path.

        Raises:
            TwinError: The model is IFC2X3, it changed on disk, or the file cannot be written.
        """
        from bim2rdt.twin.ifc_export import write_twin_ifc

        safety = [Event.from_json(json.dumps(e.data)) for e in self.store.read(kinds=[SAFETY], by_time=True)]
        return write_twin_ifc(self.model, self.state(), safety, Path(path), self.object_mesh)

    def export_bcf(self, path: str | Path) -> Path:
        """A BCF 2.1 file with one topic per deviating, missing or new element, each with the camera viewpoint
        it was seen from and a snapshot image.

        Args:
            path: The output .bcf file, written atomically.

        Returns:
            The written path.

        Raises:
            WriteError: The file cannot be written (the previous one, if any, is unchanged).
        """
        from bim2rdt.twin.bcf_export import write_bcf

        return write_bcf(self.model, self.state(), Path(path), self.object_mesh)

    def object_mesh(self, state: ElementState) -> tuple[np.ndarray, np.ndarray]:
        """The mesh of an element in its body frame: the BIM's mesh, else the family mesh, else a 0.5 m box.

        Args:
            state: The element's state.

        Returns:
            ((N,3) vertices in the body frame, metres; (M,3) faces).
        """
        if state.mesh is not None:
            return state.mesh
        if state.in_bim and self.model.has_mesh(state.global_id):
            vertices, faces = self.model.mesh(state.global_id)
            placement = self._elements[state.global_id].placement
            return (vertices - placement[:3, 3]) @ placement[:3, :3], faces
        mesh = self.family_mesh(state.family) if self.family_mesh is not None and state.family else None
        return mesh if mesh is not None else _placeholder_box()

    # ---- helpers ------------------------------------------------------------------------------------------

    def _with_meshes(self, states: dict[str, ElementState]) -> dict[str, ElementState]:
        """Objects the BIM lacks get their mesh (family mesh or stand-in box), one lookup per family."""
        meshes: dict[str | None, tuple[np.ndarray, np.ndarray]] = {}
        for global_id, state in states.items():
            if not state.in_bim:
                if state.family not in meshes:
                    meshes[state.family] = self.object_mesh(state)
                states[global_id] = dataclasses.replace(state, mesh=meshes[state.family])
        return states


    def _write(self, build: Callable[[Writer], list[TwinEvent]]) -> list[TwinEvent]:
        """One transaction under the writers' lock: catch up on others' events, build and append ours; the
        projection takes ours only once they are committed."""
        with self.store.writing() as writer:
            self._projection.apply_all(writer.read_after(self._projection.last_seq))
            appended = build(writer)
        self._projection.apply_all(appended)
        return appended

    def _catch_up(self) -> None:
        self._projection.apply_all(self.store.read(after=self._projection.last_seq))

    def _append_with_status(self, writer: Writer, event: NewEvent, status: ElementStatus) -> list[TwinEvent]:
        """Append ``event``, and a status event if it changes the element's present status (an event older than
        the element's newest one is evidence of the past and changes nothing now)."""
        appended = [writer.append(event)]
        newest = self._projection.newest_time(event.global_id)
        if newest is not None and event.time < newest:
            return appended
        before = self._projection.get(event.global_id)
        previous = before.status if before else ElementStatus.NOT_OBSERVED
        if previous is not status:
            change = {"from": previous.value, "to": status.value, "event": appended[0].seq}
            appended.append(writer.append(NewEvent(STATUS, event.time, event.global_id, event.source, change)))
        return appended

    def _safety_event(self, event: Event) -> NewEvent:
        when = _checked_time(event.time)
        related = self._zone_of(event.data.get("zone"))
        source = checked_text(event.source or "hav-monitor", "source")
        return NewEvent(SAFETY, when, related, source, json.loads(event.to_json()))

    def _known(self, global_id: str) -> BimElement | None:
        """The BIM element, or None for an object the twin found that the BIM lacks; TwinError otherwise."""
        if global_id in self._elements:
            return self._elements[global_id]
        if self._projection.get(global_id) is not None:
            return None
        raise TwinError(f"{self.model.path.name} has no element with GlobalId {global_id}")

    def _match_new(self, family: str, pose: np.ndarray) -> str | None:
        near = [(float(np.linalg.norm(s.pose[:2, 3] - pose[:2, 3])), s.global_id)
                for s in self._projection.outside_bim() if s.family == family and s.pose is not None]
        near = [entry for entry in near if entry[0] <= self.new_match_radius]
        return min(near)[1] if near else None

    def _zone_of(self, zone: str | None) -> str | None:
        for candidate in self.model.zones:
            if zone in (candidate.name, candidate.global_id):
                return candidate.global_id
        return zone if zone in self._elements else None


def _fit(observation: Observation) -> dict:
    rmse = float(observation.rmse)
    return {"rmse": rmse if math.isfinite(rmse) else None, "fitness": float(observation.fitness),
            "points": _whole(observation.points, "points"), "score": float(observation.score),
            "detector": checked_text(observation.detector, "detector", may_be_empty=True)}


def _evidence(station, frames, camera, bbox) -> dict:
    if bbox is not None:
        if isinstance(bbox, str) or len(bbox) != 4:
            raise TwinError(f"an observation's bbox is (u0, v0, u1, v1) pixels, got {len(bbox)} values")
        bbox = [_whole(v, "bbox") for v in bbox]
    return {"station": None if station is None else _whole(station, "station"),
            "frames": [_whole(f, "frames") for f in frames],
            "camera": None if camera is None else camera.tolist(), "bbox": bbox}


def _whole(value, what: str) -> int:
    """A finite number as an int (a pixel, a frame index); TwinError naming ``what`` otherwise."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
        raise TwinError(f"an observation's {what} must be finite numbers, got {value!r}")
    return int(value)


def _utc(time: float) -> str:
    import datetime

    return datetime.datetime.fromtimestamp(time, datetime.timezone.utc).isoformat(timespec="seconds")


def _checked_time(time: float) -> float:
    """UTC epoch seconds as a float: any finite real number (numpy's too, np.float32 included)."""
    if isinstance(time, bool) or not isinstance(time, numbers.Real) or not math.isfinite(time):
        raise TwinError(f"a twin time is finite UTC epoch seconds, got {time!r}")
    return float(time)


def _checked_pose(pose, what: str) -> np.ndarray:
    problem = rigid_problem(pose)
    if problem is not None:
        raise TwinError(f"{what} must be a finite 4x4 rigid pose: {problem}")
    return np.asarray(pose, dtype=float)


def _check_symmetry(symmetry: Mapping[str, float]) -> None:
    for family, order in symmetry.items():
        if not (math.isinf(order) and order > 0) and not (order >= 1 and float(order).is_integer()):
            raise TwinError(f"the symmetry of {family} is its rotational order about up (a whole number >= 1, or "
                            f"math.inf for axial), got {order}")


def _placeholder_box(size: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """A ``size`` cube standing on the body origin: the stand-in mesh of an object of unknown shape."""
    import trimesh

    box = trimesh.creation.box(extents=(size, size, size))
    return np.asarray(box.vertices) + [0.0, 0.0, size / 2], np.asarray(box.faces)
