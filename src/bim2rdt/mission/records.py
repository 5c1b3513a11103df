"""What a mission works on and what it produces: targets (BIM elements to verify), observations, the result.

An observation is perception's one record (:class:`bim2rdt.perception.observation.Observation`, re-exported here):
the mission fills its verdict in it (``status``, ``shift``, ``yaw_deg``, ``tilt_deg``, ``upright_bias``,
``reason``)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import trimesh

from bim2rdt.perception import Observation

__all__ = ["MissingElement", "MissionResult", "Observation", "Target"]


@dataclass(frozen=True)
class Target:
    """An object the mission looks for: a BIM element (GlobalId, family, placement, body mesh, and its IFC class,
    which with the family picks its tolerance preset)."""

    global_id: str
    family: str
    placement: np.ndarray
    mesh_body: trimesh.Trimesh
    ifc_class: str | None = None


@dataclass(frozen=True)
class MissingElement:
    """A planned element whose place was seen empty: its GlobalId and family, the ``station`` whose frame shows
    it best (most cells seen through), every station whose frame showed it empty (``frames``), and that best
    view's ``cells`` seen and not occluded, and the ``see_through`` fraction of them."""

    global_id: str
    family: str
    station: int
    frames: tuple[int, ...]
    see_through: float
    cells: int


@dataclass
class MissionResult:
    """Stations (T_world_camera each), the observations, the BIM targets whose place was seen empty
    (``missing``), the BIM targets never seen (``not_seen``: not looked at, or their place occluded), and the
    fits ``set_aside``: detections tied to no planned element whose points a known surface explains (a column's
    edge fitted by a tripod leg; :mod:`bim2rdt.mission.explained`). Those show no object, so they stay out of
    the observations (and the twin), each with its ``reason``, for the report."""

    stations: list[np.ndarray]
    observations: list[Observation] = field(default_factory=list)
    not_seen: list[str] = field(default_factory=list)
    missing: list[MissingElement] = field(default_factory=list)
    set_aside: list[Observation] = field(default_factory=list)
