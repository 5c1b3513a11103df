"""The twin written back into IFC through ``TwinWriter``: the as-built model of the site.

Deviating elements move to their measured pose; new objects become ``IfcBuildingElementProxy`` objects keeping
the twin's GlobalId (so the BCF topics point at them); every observed element carries a ``BIM2RDT_Observation``
pset (status, deviation, tolerance, fit, evidence); the HAV monitor's safety events become IfcEvent/IfcTask
records through the safety package's ``IfcSink``. Elements as planned keep their BIM pose: the BIM was right.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from bim2rdt.bim import BimError, BimModel, TwinWriter
from bim2rdt.bus import Event
from bim2rdt.safety import IfcSink
from bim2rdt.twin.errors import TwinError
from bim2rdt.twin.records import ElementState
from bim2rdt.twin.status import ElementStatus


def write_twin_ifc(model: BimModel, states: Mapping[str, ElementState], safety: Iterable[Event], path: Path,
                   object_mesh: Callable[[ElementState], tuple[np.ndarray, np.ndarray]]) -> Path:
    """Write ``model`` with the twin's ``states`` and ``safety`` events to ``path`` (atomically)."""
    try:
        writer = TwinWriter(model)
        for state in states.values():
            _write_state(writer, state, object_mesh)
        sink = IfcSink(writer, model)
        for event in safety:
            sink.emit(event)
        return writer.save(path)
    except BimError as error:
        raise TwinError(f"cannot write the twin back into IFC: {error}") from None


def _write_state(writer: TwinWriter, state: ElementState, object_mesh) -> None:
    if state.status is ElementStatus.NOT_OBSERVED:
        return
    if state.status is ElementStatus.NEW:
        vertices, faces = object_mesh(state)
        writer.add_object(state.family or "unknown", vertices, faces, state.pose, properties=observation_pset(state),
                          global_id=state.global_id)
        return
    if not state.in_bim:
        return  # an unverified object the BIM lacks: not confirmed enough to add
    if state.status is ElementStatus.DEVIATING:
        writer.move_element(state.global_id, state.pose)
    writer.add_properties(state.global_id, observation_pset(state))


def observation_pset(state: ElementState) -> dict:
    """The ``BIM2RDT_Observation`` properties of one element (lengths in metres, angles in degrees)."""
    props: dict = {"Status": state.status.value, "Robot": state.robot}
    if state.evidence is not None:
        props |= {"ObservedAt": datetime.fromtimestamp(state.evidence.time, timezone.utc),
                  "Station": state.evidence.station, "Frames": ",".join(map(str, state.evidence.frames)) or None}
    if state.deviation is not None:
        props |= {"TranslationMetres": state.deviation.translation, "TiltDegrees": state.deviation.tilt_deg,
                  "YawDegrees": state.deviation.yaw_deg}
    if state.tolerance is not None:
        props |= {"TolerancePreset": state.tolerance.name, "ToleranceMetres": state.tolerance.translation,
                  "ToleranceDegrees": state.tolerance.rotation_deg}
    if state.fit is not None:
        props |= {"Fitness": state.fit.fitness, "RmseMetres": state.fit.rmse, "ScenePoints": state.fit.points,
                  "DetectorScore": state.fit.score, "Detector": state.fit.detector or None}
    return props
