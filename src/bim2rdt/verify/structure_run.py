"""verify's structure judge: each accepted frame (its depth not miscalibrated) handed to the structure survey and
the deviation maps while it is at hand, then every permanent element judged (``structure.json``), the maps
written (``deviation/frame_NNN.png``, ``deviation.ply``) and the judgements recorded into the twin."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.structure import (DeviationMaps, StructureConfig, StructureJudgement, StructureSurvey, StructureView,
                               judgements, tolerance_of, write_structure_json)
from bim2rdt.twin import Deviation, DigitalTwin, ElementStatus, Tolerance
from bim2rdt.verify.chain import FrameResult, sensor_points

STRUCTURE_JSON = "structure.json"
DEVIATION_DIR = "deviation"
DEVIATION_PLY = "deviation.ply"


class StructureRun:
    """The structure judge and deviation maps of one verify run into ``out_dir``.

    Args:
        model: The BIM, loaded with geometry.
        out_dir: The verify folder.
        config: The judge's settings (``Settings.structure``).
    """

    def __init__(self, model: BimModel, out_dir: Path, config: StructureConfig = StructureConfig()) -> None:
        self.model, self.out_dir, self.config = model, Path(out_dir), config
        self.survey = StructureSurvey(model, config)
        self.maps = DeviationMaps(model, self.out_dir / DEVIATION_DIR, config)
        self.seen: dict[int, tuple[float, np.ndarray]] = {}
        self.ply: Path | None = None

    def look(self, frame: object, result: FrameResult, points: np.ndarray | None = None) -> None:
        """Take one frame's evidence (skipped when its fix was refused or its depth looks miscalibrated).

        Args:
            frame: The :class:`Frame` or scan verify read.
            result: Its result (the fixed pose).
            points: Its :func:`~bim2rdt.verify.chain.sensor_points`, when the caller has them (verify does: a
                frame's backprojection is not repeated).
        """
        if not result.accepted or (result.depth is not None and result.depth.miscalibrated):
            return
        points = sensor_points(frame) if points is None else points
        self.survey.add(StructureView(result.index, points, result.pose))
        self.maps.add(result.index, frame, points, result.pose)
        self.seen[result.index] = (result.time if result.time is not None else float(result.index), result.pose)

    def finish(self) -> list[StructureJudgement]:
        """Judge every permanent element and write ``structure.json`` and ``deviation.ply``.

        Returns:
            The judgements, in model order.
        """
        judged = judgements(self.survey)
        write_structure_json(judged, self.out_dir / STRUCTURE_JSON)
        self.ply = self.maps.finish(self.out_dir / DEVIATION_PLY)
        return judged

    def record(self, twin: DigitalTwin, judged: list[StructureJudgement]) -> int:
        """Record the judgements into the twin (see :func:`record_structure`).

        Args:
            twin: The run's twin.
            judged: :meth:`finish`'s judgements.

        Returns:
            How many were recorded.
        """
        return record_structure(twin, judged, self.model, self.config, self.seen)


def record_structure(twin: DigitalTwin, judged: list[StructureJudgement], model: BimModel, config: StructureConfig,
                     seen: dict[int, tuple[float, np.ndarray]]) -> int:
    """Record each judgement that says something (as planned, deviating, not built) into the twin, at the time and
    camera of the last frame that saw the element. An element the twin already judged by registering its body
    (the demo's columns) keeps that verdict: the object path measured its whole body, not its faces.

    Args:
        twin: The twin.
        judged: The judgements.
        model: The BIM.
        config: The judge's settings (the tolerances recorded).
        seen: {frame index: (time UTC s, T_world_sensor)} of the frames the judge took.

    Returns:
        How many were recorded.
    """
    states = twin.state()
    elements = {el.global_id: el for el in model.elements}
    count = 0
    for judgement in judged:
        status = ElementStatus(judgement.status)
        frames = [f for f in judgement.frames if f in seen]
        if status is ElementStatus.NOT_OBSERVED or not frames:
            continue
        if states[judgement.global_id].status is not ElementStatus.NOT_OBSERVED:
            continue
        when, camera = seen[frames[-1]]
        pose = _measured_pose(elements[judgement.global_id].placement, judgement)
        twin.record_structure(judgement.global_id, status, when, pose=pose, deviation=_deviation(judgement),
                              tolerance=tolerance_record(judgement.ifc_class, config), frames=frames, camera=camera,
                              reason=judgement.reason, measured=judgement.to_dict())
        count += 1
    return count


def tolerance_record(ifc_class: str, config: StructureConfig) -> Tolerance:
    """The class's structure tolerance as the twin records it, named by its USIBD band.

    Args:
        ifc_class: The element's IFC class.
        config: The judge's settings.

    Returns:
        The tolerance.
    """
    tolerance = tolerance_of(ifc_class, config)
    bands = ((0.001, "LOA50"), (0.005, "LOA40"), (0.015, "LOA30"), (0.05, "LOA20"))
    band = next((name for limit, name in bands if tolerance.translation <= limit + 1e-9), "LOA10")
    return Tolerance(f"structure {band}", tolerance.translation, tolerance.rotation_deg)


def _measured_pose(placement: np.ndarray, judgement: StructureJudgement) -> np.ndarray | None:
    if judgement.status == "not built":
        return None
    pose = np.array(placement, dtype=float)
    if judgement.offset_m is not None:
        pose[:3, 3] += judgement.offset_m
    return pose


def _deviation(judgement: StructureJudgement) -> Deviation | None:
    if judgement.status == "not built":
        return None
    size = (float(np.linalg.norm(judgement.offset_m)) if judgement.offset_m is not None
            else abs(judgement.median_mm or 0.0) / 1000)
    return Deviation(size, judgement.rotation_deg or 0.0, 0.0)
