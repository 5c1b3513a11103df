"""What perception hands the mission: one detected object, its family label and its world points."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Detection:
    """What perception hands the mission: a family label and the object's world points (N, 3) from one frame."""

    family: str
    points_world: np.ndarray
    station: int
