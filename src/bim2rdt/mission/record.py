"""Recording a mission into the twin: the last step of the robot loop (:mod:`bim2rdt.mission.robot`).

Each observation is recorded at the time its station was reached, with that station's camera as the view it was
seen best from; each planned element whose place was seen empty is marked missing, with the station that saw it
so. The twin judges each record against its tolerance presets (the same judge the mission used)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence

import numpy as np

from bim2rdt.mission.records import MissingElement, Observation
from bim2rdt.twin import DigitalTwin

STATION_SECONDS = 30.0
"""Seconds between two stations when the route logged no arrival times (the observations' times)."""


def record_mission(twin: DigitalTwin, observations: Iterable[Observation], stations: Sequence[np.ndarray],
                   start: float = 0.0, times: Mapping[int, float] | None = None,
                   missing: Iterable[MissingElement] = ()) -> None:
    """Record each observation at the time its station was reached (``times[station]`` when the robot's route
    logged it, else ``start`` + ``STATION_SECONDS`` per station; s), with that station's camera (``stations``,
    T_world_camera each) as the view it was seen from; and each element whose place was seen empty as missing.

    Args:
        twin: The twin to record into.
        observations: The mission's observations, each with the index of its station.
        stations: ``T_world_camera`` (4x4, metres) of each station, by index.
        start: The mission's start, UTC seconds, when ``times`` is None.
        times: {station: UTC seconds the robot reached it}, as its route logged them.
        missing: Elements whose place was seen empty, each with its station and frames.
    """
    def when(station: int | None) -> float:
        return times[station] if times else start + STATION_SECONDS * (station or 0)

    for obs in observations:
        camera = stations[obs.station] if obs.station is not None else None
        twin.record(obs, when(obs.station), camera=camera)
    for gone in missing:
        twin.mark_missing(gone.global_id, when(gone.station), station=gone.station, frames=gone.frames,
                          camera=stations[gone.station])
