"""How far a measured pose is from the BIM's: translation of the origin, tilt of the up axis, yaw about it.

Yaw is taken modulo the family's rotational symmetry about its body up axis (``symmetry`` is the order n of
``UprightPrior.symmetry``: a square-based cone is 4, a pallet 2, a drum ``math.inf``): the measured pose is first
turned by the symmetry that brings it closest to the BIM's (``registration.symmetry.closest_equivalent``), so a
pallet turned by 180 degrees is where the BIM wants it. Poses are T_world_model (4x4, metres); angles degrees.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bim2rdt.registration import closest_equivalent


@dataclass(frozen=True)
class Deviation:
    """``translation`` (m) between the origins, ``tilt_deg`` between the up axes, ``yaw_deg`` about up, within
    +-180/n for a family of symmetry order n (0 for an axially symmetric one)."""

    translation: float
    tilt_deg: float
    yaw_deg: float

    def within(self, translation: float, rotation_deg: float) -> bool:
        """Whether the deviation is inside a tolerance.

        Args:
            translation: The largest translation, metres.
            rotation_deg: The largest tilt and the largest yaw, degrees.

        Returns:
            True when translation, tilt and absolute yaw are all within their bounds.
        """
        return (self.translation <= translation and self.tilt_deg <= rotation_deg
                and abs(self.yaw_deg) <= rotation_deg)

    def to_dict(self) -> dict:
        """The fields as JSON-ready data.

        Returns:
            {field: value}: translation (metres), tilt_deg and yaw_deg (degrees).
        """
        return {"translation": self.translation, "tilt_deg": self.tilt_deg, "yaw_deg": self.yaw_deg}


def pose_deviation(T_bim: np.ndarray, T_measured: np.ndarray, symmetry: float = 1) -> Deviation:
    """The deviation of ``T_measured`` from ``T_bim``, in the BIM element's body frame (an element the BIM
    places tilted is judged against its own up axis, not against world z).

    Args:
        T_bim: The element's BIM pose, 4x4 model-to-world, metres.
        T_measured: The measured pose, 4x4 model-to-world, metres.
        symmetry: The family's rotational order about its up axis (``math.inf`` for axial): yaw is taken to the
            nearest equivalent pose.

    Returns:
        Translation between the origins (metres), tilt between the up axes and yaw about up (degrees).
    """
    equivalent = closest_equivalent(T_measured, T_bim, symmetry)
    relative = T_bim[:3, :3].T @ equivalent[:3, :3]
    tilt = math.degrees(math.acos(float(np.clip(relative[2, 2], -1.0, 1.0))))
    # the twist about body z that best explains the rotation (argmax of tr(R Rz(-theta)))
    yaw = math.degrees(math.atan2(relative[1, 0] - relative[0, 1], relative[0, 0] + relative[1, 1]))
    translation = float(np.linalg.norm(T_measured[:3, 3] - T_bim[:3, 3]))
    return Deviation(translation, tilt, yaw)
