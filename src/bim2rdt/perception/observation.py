"""One physical object as perception found it: which BIM element (if any), where it is, how well it fit, and
(once judged against the BIM) the verdict.

This is the one record every consumer shares: perception fills what it found, the mission fills its verdict in
the same record (``status`` and the deltas behind it), the twin records it, the dashboard shows it. ``pose`` is
T_world_model (4x4, metres, world z-up). :class:`ElementStatus` lives here, under the record, so that the record's
verdict is typed at the layer that makes the record; the twin re-exports it (``bim2rdt.twin.ElementStatus``)."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from bim2rdt.registration import RegistrationResult

UNKNOWN_FAMILY = "unknown"
"""The family of an object no candidate family explains (a person, clutter nobody modelled)."""


class ElementStatus(str, Enum):
    """What the robot's evidence says about one element against the BIM (the value is what reports print).

    ``DEVIATING`` is out of tolerance (for a site object: moved or turned; for a column: out of plumb or off its
    grid line); ``MISSING`` is its place seen empty; ``NEW`` is an object the BIM does not have;
    ``UNVERIFIED`` is seen, but the fit is too poor (or the view too weak) to judge; ``NOT_BUILT`` is a permanent
    element (a wall, a slab) whose surface was in clear view with nothing on it and free space seen through it
    (:mod:`bim2rdt.structure`)."""

    NOT_OBSERVED = "not observed"
    AS_PLANNED = "as planned"
    DEVIATING = "deviating"
    MISSING = "missing"
    NEW = "new"
    UNVERIFIED = "unverified"
    NOT_BUILT = "not built"

    def __str__(self) -> str:
        return self.value


@dataclass
class Observation:
    """``family`` (a BIM family or :data:`UNKNOWN_FAMILY`), ``global_id`` (the matched BIM element's GlobalId,
    None for an object the BIM lacks), ``pose`` (T_world_model), ``rmse`` (m) and ``fitness`` (0-1) of the
    registration, ``points`` (scene points used), detector ``score`` (0-1), ``bbox`` (u0, v0, u1, v1) pixels in
    the frame it was seen best, ``detector`` (its name), and where it was seen from (``station``, ``frames``).

    The verdict, once judged against the BIM (None / zero until then; the mission fills it): ``status``, the
    deltas behind it, ``shift`` (m, horizontal), ``yaw_deg`` and ``tilt_deg`` against the BIM placement, modulo
    the family's symmetry (0 for new objects), the prior's ``upright_bias``, and ``reason``: what follows
    "unverified" (e.g. "along x (the view does not pin the pose down there, ...)"), empty otherwise."""

    family: str
    global_id: str | None
    pose: np.ndarray
    rmse: float
    fitness: float
    points: int
    score: float = 1.0
    bbox: tuple[int, int, int, int] | None = None
    detector: str = ""
    station: int | None = None
    frames: tuple[int, ...] = field(default=())
    fit: RegistrationResult | None = None
    status: ElementStatus | None = None
    shift: float = 0.0
    yaw_deg: float = 0.0
    tilt_deg: float = 0.0
    upright_bias: float | None = None
    reason: str = ""
