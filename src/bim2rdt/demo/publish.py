"""``bim2rdt demo --publish results.mcap``: the day's results as the bag ``verify --publish`` writes
(:mod:`bim2rdt.verify.publish`), from the demo's mission: ``/tf`` ``map -> odom`` from each station's BIM-fixed
pose and the robot's odometry at that capture (the poses ``--record`` writes, so both bags play together),
``/bim2rdt/pose`` with the last applied fix's covariance, ``/bim2rdt/objects`` at the twin's poses, and ``/map``
and ``/keepout_filter_mask`` equal to the Nav2 maps the report writes (``nav2/site.*``)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bim2rdt.demo.routes import known_grid
from bim2rdt.demo.site_day import SiteDay
from bim2rdt.verify.publish import publish_results


@dataclass(frozen=True)
class StationResult:
    """One station's look as :func:`~bim2rdt.verify.publish.publish_results` takes a frame: its capture time on
    the robot's clock, whether a BIM fix was applied, the fixed pose (T_map_camera), its covariance (6x6) and the
    robot's odometry then (``recorded``: T_odom_camera)."""

    time: float
    accepted: bool
    pose: np.ndarray
    covariance: np.ndarray | None
    recorded: np.ndarray


def station_results(day: SiteDay) -> list[StationResult]:
    """Each localized station of the day (needs ``day.odometry``: run the day with ``keep_odometry`` or
    ``record``)."""
    if day.localization is None or day.odometry is None:
        return []
    results = []
    for station in day.localization.stations:
        applied = [look.fix for look in station.looks if look.applied and look.fix is not None]
        time, T_odom_camera = day.odometry[station.located.capture]
        results.append(StationResult(time, bool(applied), station.estimate,
                                     applied[-1].covariance if applied else None, T_odom_camera))
    return results


def publish_day(path: Path, day: SiteDay) -> Path:
    """Write the results bag at ``path`` (NAME.mcap: the rosbag2 folder NAME/); returns the folder."""
    states = day.twin.state() if day.twin is not None else {}
    return publish_results(path, station_results(day), states, day.model, known_grid(day, states))
