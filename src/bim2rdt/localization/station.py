"""One station: fix the frame on the BIM, and when the view leaves a direction free (a single wall) or is
refused, turn the camera and look again until the station is pinned.

A degenerate fix corrects only what it sees, so the position along a lone wall keeps the odometry's drift; a
robot that knows this (``degenerate`` says it) turns and takes a second frame, as a surveyor sights a second
mark. The robot's turn is a callback: it turns in place by an angle, captures, and reports its odometry.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.localization.config import LocalizationConfig
from bim2rdt.localization.filter import PoseFilter, StationFix, fuse_frame
from bim2rdt.perception import Frame


@dataclass(frozen=True)
class Turned:
    """What the robot reports after turning in place: the new ``frame``, and its odometry ``increment``
    (forward, left, up m, turn rad), ``distance`` walked and angle ``turned`` (rad) during the turn."""

    frame: Frame
    increment: np.ndarray
    distance: float
    turned: float


def pinned(station: StationFix) -> bool:
    """Tell whether a station's fix pins the pose.

    Args:
        station: What one look did to the filter.

    Returns:
        True when its fix was fused and constrains every direction (position and yaw).
    """
    return station.applied and not station.fix.degenerate and not station.fix.degenerate_yaw


def localize_station(pose_filter: PoseFilter, model: BimModel, frame: Frame, R_level_camera: np.ndarray,
                     turn: Callable[[float], Turned] | None = None, config: LocalizationConfig | None = None,
                     up: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 1.0),
                     turn_back: bool = False) -> list[StationFix]:
    """Fuse the station's frame; while the station is not pinned, turn by the next of ``look_around_deg``
    (absolute, from the first heading) and fuse that frame too. With ``turn_back`` the camera then turns back to
    the first heading and fuses the frame there as well (the station's view, now with a pinned pose); otherwise
    it is left at the last look.

    Args:
        pose_filter: The filter; predicted and updated in place.
        model: The BIM, loaded with geometry.
        frame: The station's first RGB-D frame.
        R_level_camera: (3,3) the IMU's tilt: camera (OpenCV axes) to the levelled heading frame.
        turn: Turns the robot by a relative angle (radians) and returns the new frame with its odometry; None
            never looks around.
        config: Localization's settings (``look_around_deg``); None uses the defaults.
        up: The measured world up, a unit 3-vector.
        turn_back: Turn back to the first heading at the end and fuse that frame too.

    Returns:
        Every look's result, first first.
    """
    cfg = config or LocalizationConfig()
    looks = [fuse_frame(pose_filter, frame, model, R_level_camera, up, cfg)]
    heading = 0.0
    for angle in (np.deg2rad(a) for a in cfg.look_around_deg):
        if turn is None or pinned(looks[-1]):
            break
        looks.append(_look(pose_filter, model, turn(angle - heading), R_level_camera, up, cfg))
        heading = angle
    if turn_back and heading != 0.0:
        looks.append(_look(pose_filter, model, turn(-heading), R_level_camera, up, cfg))
    return looks


def _look(pose_filter: PoseFilter, model: BimModel, turned: Turned, R_level_camera: np.ndarray, up,
          cfg: LocalizationConfig) -> StationFix:
    pose_filter.predict(turned.increment, turned.distance, turned.turned)
    return fuse_frame(pose_filter, turned.frame, model, R_level_camera, up, cfg)
