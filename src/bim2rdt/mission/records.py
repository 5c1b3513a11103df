"""What a mission works on and what it produces: targets (BIM elements to verify), observations, the result."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import trimesh

from bim2rdt.registration import RegistrationResult


@dataclass(frozen=True)
class Target:
    """An object the mission looks for: a BIM element (GlobalId, family, placement, body mesh)."""

    global_id: str
    family: str
    placement: np.ndarray
    mesh_body: trimesh.Trimesh


@dataclass
class Observation:
    """One registered object and the mission's verdict on it."""

    family: str
    global_id: str | None
    status: str  # "as-planned" | "moved" | "new" | "unverified"
    pose: np.ndarray
    fit: RegistrationResult
    points: int
    station: int
    shift: float  # m, horizontal, against the BIM placement (0 for new objects)
    yaw_deg: float
    tilt_deg: float
    upright_bias: float
    frames: tuple[int, ...] = ()  # every station it was seen from (its views merged into this observation)


@dataclass
class MissionResult:
    """Stations (T_world_camera each), the observations, and the BIM targets never seen."""

    stations: list[np.ndarray]
    observations: list[Observation] = field(default_factory=list)
    not_seen: list[str] = field(default_factory=list)
