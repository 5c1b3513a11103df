"""The demo's structure: the permanent elements judged from the frames the robot's camera read at its stations,
each placed where the robot believed it was (its BIM-fixed estimate, never the simulator's truth), written as
``structure.json`` and recorded into the day's twin before it is exported (:mod:`bim2rdt.structure`)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from bim2rdt.bim import BimModel
from bim2rdt.perception.frame import Frame
from bim2rdt.structure import (StructureConfig, StructureJudgement, StructureSurvey, StructureView,
                               write_structure_json)
from bim2rdt.structure.judge import judgements
from bim2rdt.twin import DigitalTwin
from bim2rdt.localization import depth_points
from bim2rdt.verify.structure_run import STRUCTURE_JSON, record_structure


def judge_day_structure(model: BimModel, frames: Mapping[int, Frame], times: Mapping[int, float],
                        twin: DigitalTwin, out_dir: Path,
                        config: StructureConfig = StructureConfig()) -> list[StructureJudgement]:
    """Judge the structure from each station's frame, write ``out_dir/structure.json`` and record the judgements.

    Args:
        model: The site's BIM.
        frames: {station: the frame the robot read there, with its estimated ``T_world_camera``}.
        times: {station: UTC seconds the robot reached it}.
        twin: The day's twin (objects already recorded: their verdicts stay).
        out_dir: The demo's folder.
        config: The judge's settings (``Settings.structure``).

    Returns:
        The judgements, in model order.
    """
    survey = StructureSurvey(model, config)
    seen = {}
    for station in sorted(frames):
        frame = frames[station]
        if frame is None or frame.T_world_camera is None:
            continue
        survey.add(StructureView(station, depth_points(frame), frame.T_world_camera))
        seen[station] = (times.get(station, float(station)), frame.T_world_camera)
    judged = judgements(survey)
    write_structure_json(judged, Path(out_dir) / STRUCTURE_JSON)
    record_structure(twin, judged, model, config, seen)
    return judged
