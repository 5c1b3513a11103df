"""What the twin hands out: one element's state, and the events of its history (plain dataclasses, numpy poses).

Units: metres, degrees, UTC epoch seconds. ``pose`` and ``camera`` are 4x4 T_world_model / T_world_camera (the
camera in the OpenCV convention: x right, y down, z forward)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from bim2rdt.twin.deviation import Deviation
from bim2rdt.twin.status import ElementStatus
from bim2rdt.twin.tolerance import Tolerance

OBSERVATION = "observation"
"""An object the robot found and registered (evidence and verdict)."""
MISSING = "missing"
"""An element whose place the robot saw empty."""
STATUS = "status"
"""An element's present status changed (``data``: ``from``, ``to``, ``event``: the seq that changed it)."""
STRUCTURE = "structure"
"""A permanent element judged by the structure judge (``data``: its status, measured pose, deviation, tolerance,
evidence, and ``structure``: the judge's figures)."""
SAFETY = "safety"
"""A safety event of the HAV monitor (``data``: the bus event)."""
EVENT_KINDS = (OBSERVATION, MISSING, STATUS, SAFETY, STRUCTURE)


@dataclass(frozen=True)
class Fit:
    """How well the registration explained the points: ``rmse`` (m; None for a fit with no inlier), ``fitness``
    (0-1), scene ``points``, the detector's ``score`` (0-1) and name."""

    rmse: float | None
    fitness: float
    points: int
    score: float
    detector: str

    def to_dict(self) -> dict:
        """The fields as JSON-ready data.

        Returns:
            {field: value}: rmse (metres), fitness (0-1), points, score and detector.
        """
        return {"rmse": self.rmse, "fitness": self.fitness, "points": self.points, "score": self.score,
                "detector": self.detector}


@dataclass(frozen=True)
class Evidence:
    """Where and when it was seen: robot ``station`` index, frame indices, ``time`` (UTC s), the camera pose of
    the view it was seen best from (None when the recorder did not give one), and the box in that frame."""

    station: int | None
    frames: tuple[int, ...]
    time: float
    camera: np.ndarray | None = None
    bbox: tuple[int, int, int, int] | None = None

    def to_dict(self) -> dict:
        """The fields as JSON-ready data.

        Returns:
            {field: value}: station, frames, time (UTC seconds), camera (4x4 ``T_world_camera`` as nested lists) and bbox.
        """
        return {"station": self.station, "frames": list(self.frames), "time": self.time,
                "camera": None if self.camera is None else self.camera.tolist(),
                "bbox": None if self.bbox is None else list(self.bbox)}


@dataclass(frozen=True, eq=False)
class ElementState:
    """One element as the twin knows it. ``ifc_class`` is None for an object the BIM lacks (status NEW, or
    UNVERIFIED when its fit is too poor). ``deviation`` is against the BIM pose (None when not observed, missing
    or new); ``tolerance`` is the preset it was judged by; ``pose`` the measured T_world_model. ``mesh`` is the
    body-frame (vertices (N,3), faces (M,3)) of an object the BIM lacks (its family's mesh, or a stand-in box), so
    a planner or a viewer can draw it; None for BIM elements (the BIM has their mesh). It is not part of the
    state's JSON or equality."""

    global_id: str
    family: str | None
    ifc_class: str | None
    status: ElementStatus
    tolerance: Tolerance | None = None
    deviation: Deviation | None = None
    fit: Fit | None = None
    evidence: Evidence | None = None
    robot: str | None = None
    pose: np.ndarray | None = None
    mesh: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def in_bim(self) -> bool:
        """True for an element of the BIM; False for an object the BIM lacks."""
        return self.ifc_class is not None

    def to_dict(self) -> dict:
        """The state as JSON-ready data (the JSON export and the dashboard use this).

        Returns:
            Every field but ``mesh``; the pose as nested lists (4x4, metres).
        """
        def plain(value):
            return None if value is None else value.to_dict()

        return {"global_id": self.global_id, "family": self.family, "ifc_class": self.ifc_class,
                "status": self.status.value, "tolerance": plain(self.tolerance), "deviation": plain(self.deviation),
                "fit": plain(self.fit), "evidence": plain(self.evidence), "robot": self.robot,
                "pose": None if self.pose is None else self.pose.tolist()}

    def __eq__(self, other: object) -> bool:
        return self.to_dict() == other.to_dict() if isinstance(other, ElementState) else NotImplemented


@dataclass(frozen=True)
class TwinEvent:
    """One entry of the append-only history: ``seq`` (store order, a cursor for pollers), ``kind`` (see
    :data:`EVENT_KINDS`), ``time`` (when it happened, UTC s), the element it is about (None for a safety event
    no element is linked to), ``source`` (the robot or device), ``data`` and ``recorded`` (when it was stored)."""

    seq: int
    kind: str
    time: float
    global_id: str | None
    source: str
    data: dict[str, Any] = field(default_factory=dict)
    recorded: float = 0.0
