"""What a detector finds in a frame, and what perception hands the mission: one object's label, family, image
region and (once its corners have depth) its world points."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Detection:
    """One detected object. ``family`` is a BIM family (or ``"unknown"``), ``label`` the detector's own class
    text ("traffic cone"), ``bbox`` (u0, v0, u1, v1) pixels with exclusive ends, ``mask`` (H, W) bool or None,
    ``score`` 0-1, ``detector`` its name; ``points_world`` (N, 3) the object's points once perception has them,
    ``station`` the frame's index in a mission. ``pose`` is a detector's own T_world_model guess, if it has one
    (the geometric detector registers to name); ``reason`` says why a detection cannot be used (None if it can)."""

    family: str
    points_world: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    station: int | None = None
    label: str = ""
    bbox: tuple[int, int, int, int] | None = None
    mask: np.ndarray | None = field(default=None, repr=False)
    score: float = 1.0
    detector: str = ""
    pose: np.ndarray | None = field(default=None, repr=False)
    reason: str | None = None
