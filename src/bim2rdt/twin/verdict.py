"""The twin's verdict on one observation against the BIM: as planned, deviating, new or unverified.

A fit whose fitness is under ``min_fitness`` cannot be judged (unverified), however close it lands. Otherwise an
object the BIM lacks is new, and a BIM element is as planned when its translation, tilt and yaw are all within
its tolerance preset, deviating when any is beyond it.
"""

from __future__ import annotations

import numpy as np

from bim2rdt.bim import BimElement
from bim2rdt.twin.deviation import Deviation, pose_deviation
from bim2rdt.twin.status import ElementStatus
from bim2rdt.twin.tolerance import Tolerance


def judge_observation(pose: np.ndarray, fitness: float, element: BimElement | None, tolerance: Tolerance | None,
          symmetry: float, min_fitness: float) -> tuple[ElementStatus, Deviation | None]:
    """The status and the deviation from the BIM pose (None for an object the BIM lacks)."""
    deviation = pose_deviation(element.placement, pose, symmetry) if element is not None else None
    if not fit_trusted(fitness, min_fitness):
        return ElementStatus.UNVERIFIED, deviation
    if element is None:
        return ElementStatus.NEW, None
    return against_tolerance(deviation, tolerance), deviation


def fit_trusted(fitness: float, min_fitness: float) -> bool:
    """Whether a fit explains enough of its points (``fitness``, a fraction) to be judged at all: the one rule
    the twin and the mission share, with the one setting ``Settings.twin.min_fitness``. Under it the object is
    unverified, however close it lands.

    Args:
        fitness: The fraction of the fit's points on the body.
        min_fitness: The least fraction trusted.

    Returns:
        True when the fit may be judged.
    """
    return fitness >= min_fitness


def against_tolerance(deviation: Deviation, tolerance: Tolerance) -> ElementStatus:
    """Judge a deviation against a tolerance preset: the one judge of both, used by the twin and by the mission
    (which supplies the deviation), so their verdicts agree.

    Args:
        deviation: How far an observed pose is from the BIM's: translation (m), tilt and yaw (degrees).
        tolerance: The preset: the largest translation (m) and the largest tilt or yaw (degrees).

    Returns:
        AS_PLANNED when translation, tilt and yaw are all within the preset, else DEVIATING.
    """
    within = deviation.within(tolerance.translation, tolerance.rotation_deg)
    return ElementStatus.AS_PLANNED if within else ElementStatus.DEVIATING
