"""Odometry between stations and BIM fixes at stations, fused by an extended Kalman filter over the camera's
(x, y, z, yaw); roll and pitch come from the IMU and are not filtered.

Predict: an odometry increment moves the state in its heading frame; its noise grows with the distance walked
(legged odometry drifts a fraction of the distance, and its heading a rate per metre) and with the angle turned.
Call it once per leg with the leg's summed increment: drift is a bias, and many small white-noise steps would
understate it.

Update: a fix (:class:`~bim2rdt.localization.Localization`) enters in information form,
P+ = (P^-1 + A)^-1, x+ = x + P+ A (z - x), with A the fix's information over (x, y, z, yaw). A is zero along
the directions the view cannot constrain, so a degenerate fix (one long wall) corrects only what it sees and the
position along the wall keeps the odometry's estimate and uncertainty. A rejected fix
(:class:`~bim2rdt.localization.LocalizationError`) is simply not applied: the filter keeps the odometry.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bim2rdt.localization.fix import Localization
from bim2rdt.localization.planar import compose, to_planar, wrap

FIX_AXES = [0, 1, 2, 5]
"""Rows of a fix's (dx, dy, dz, dtheta_x, dtheta_y, dtheta_z) information that are the filter's (x, y, z, yaw)."""


@dataclass(frozen=True)
class OdometryNoise:
    """What the filter assumes of the odometry (1 sigma): ``drift_fraction`` of the distance walked, per
    horizontal axis; ``heading_rate_deg_per_m`` of heading per metre walked; ``turn_fraction`` of each turn;
    ``vertical_fraction`` of the distance in height. The defaults match a legged robot's 2 % and 1 deg / 10 m."""

    drift_fraction: float = 0.02
    heading_rate_deg_per_m: float = 0.1
    turn_fraction: float = 0.01
    vertical_fraction: float = 0.002

    def covariance(self, distance: float, turned: float) -> np.ndarray:
        """Process noise (4, 4) of an increment over ``distance`` m with ``turned`` rad of turning."""
        horizontal = (self.drift_fraction * distance) ** 2
        yaw = (np.deg2rad(self.heading_rate_deg_per_m) * distance) ** 2 + (self.turn_fraction * turned) ** 2
        return np.diag([horizontal, horizontal, (self.vertical_fraction * distance) ** 2, yaw])


class PoseFilter:
    """EKF over the camera's planar state (x, y, z, yaw): :meth:`predict` with odometry, :meth:`update` with a
    BIM fix. ``state`` (4,) and ``covariance`` (4, 4) are the current estimate."""

    def __init__(self, state: np.ndarray, covariance: np.ndarray, noise: OdometryNoise = OdometryNoise()):
        self.state = np.asarray(state, dtype=float).copy()
        self.covariance = np.asarray(covariance, dtype=float).copy()
        self.noise = noise

    def predict(self, increment: np.ndarray, distance: float | None = None, turned: float | None = None) -> None:
        """Move by an odometry ``increment`` (forward, left, up m, turn rad) in the heading frame; ``distance``
        walked and angle ``turned`` (default: the increment's own length and turn) set the added noise."""
        increment = np.asarray(increment, dtype=float)
        distance = float(np.hypot(*increment[:2])) if distance is None else distance
        turned = abs(float(increment[3])) if turned is None else turned
        yaw = self.state[3]
        F = np.eye(4)  # d(compose)/d(state): the shift turns with the heading
        F[0, 3] = -np.sin(yaw) * increment[0] - np.cos(yaw) * increment[1]
        F[1, 3] = np.cos(yaw) * increment[0] - np.sin(yaw) * increment[1]
        G = np.eye(4)  # d(compose)/d(increment)
        G[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
        self.state = compose(self.state, increment)
        self.covariance = F @ self.covariance @ F.T + G @ self.noise.covariance(distance, turned) @ G.T

    def update(self, fix: Localization) -> np.ndarray:
        """Fuse a BIM fix; returns the correction applied to the state (4,). Directions the fix cannot
        constrain carry no information and are left as they were."""
        measured, _ = to_planar(fix.pose)
        information = fix.information[np.ix_(FIX_AXES, FIX_AXES)]
        innovation = measured - self.state
        innovation[3] = wrap(innovation[3])
        posterior = np.linalg.inv(np.linalg.inv(self.covariance) + information)
        correction = posterior @ information @ innovation
        self.state = self.state + correction
        self.state[3] = wrap(self.state[3])
        self.covariance = 0.5 * (posterior + posterior.T)
        return correction
