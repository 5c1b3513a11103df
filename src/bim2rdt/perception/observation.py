"""One physical object as perception found it: which BIM element (if any), where it is, and how well it fit.

This is the record every consumer shares: the mission adds its verdict to it, the twin records it, the
dashboard shows it. ``pose`` is T_world_model (4x4, metres, world z-up)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bim2rdt.registration import RegistrationResult

UNKNOWN_FAMILY = "unknown"
"""The family of an object no candidate family explains (a person, clutter nobody modelled)."""


@dataclass
class Observation:
    """``family`` (a BIM family or :data:`UNKNOWN_FAMILY`), ``global_id`` (the matched BIM element's GlobalId,
    None for an object the BIM lacks), ``pose`` (T_world_model), ``rmse`` (m) and ``fitness`` (0-1) of the
    registration, ``points`` (scene points used), detector ``score`` (0-1), ``bbox`` (u0, v0, u1, v1) pixels in
    the frame it was seen best, ``detector`` (its name), and where it was seen from (``station``, ``frames``)."""

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
