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
(:class:`~bim2rdt.localization.LocalizationError`) is simply not applied: the filter keeps the odometry. Nor is a
fix that lies beyond a chi-square gate of the prediction over the directions it constrains (an alias: a view
that lines up with the wrong walls when the prior is far off).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from bim2rdt.bim import BimModel
from bim2rdt.localization.config import LocalizationConfig
from bim2rdt.localization.errors import LocalizationError
from bim2rdt.localization.fix import Localization, localize
from bim2rdt.localization.planar import compose, from_planar, to_planar, wrap
from bim2rdt.perception import Frame

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
        """The process noise of one odometry increment.

        Args:
            distance: Distance walked, metres.
            turned: Angle turned, radians.

        Returns:
            (4,4) diagonal covariance over (x, y, z, yaw): m^2 and rad^2.
        """
        horizontal = (self.drift_fraction * distance) ** 2
        yaw = (np.deg2rad(self.heading_rate_deg_per_m) * distance) ** 2 + (self.turn_fraction * turned) ** 2
        return np.diag([horizontal, horizontal, (self.vertical_fraction * distance) ** 2, yaw])


class PoseFilter:
    """EKF over the camera's planar state (x, y, z, yaw): :meth:`predict` with odometry, :meth:`update` with a
    BIM fix. ``state`` (4,) and ``covariance`` (4, 4) are the current estimate.

    Args:
        state: The initial (x, y, z, yaw): world metres and radians about world z.
        covariance: (4,4) its covariance, m^2 and rad^2.
        noise: What the filter assumes of the odometry.
        gate_probability: A fix further from the prediction than this chi-square quantile is refused.
    """

    def __init__(self, state: np.ndarray, covariance: np.ndarray, noise: OdometryNoise = OdometryNoise(),
                 gate_probability: float = 0.9999):
        self.state = np.asarray(state, dtype=float).copy()
        self.covariance = np.asarray(covariance, dtype=float).copy()
        self.noise = noise
        self.gate_probability = gate_probability

    def predict(self, increment: np.ndarray, distance: float | None = None, turned: float | None = None) -> None:
        """Move the estimate by an odometry increment and grow its covariance.

        Args:
            increment: (forward, left, up, turn): metres in the heading frame, and radians.
            distance: Distance walked, metres, for the added noise; None uses the increment's own length.
            turned: Angle turned, radians, for the added noise; None uses the increment's own turn.
        """
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

    def surprise(self, fix: Localization) -> tuple[float, float]:
        """(squared Mahalanobis distance of the fix from the prediction over the directions it constrains, the
        chi-square bound at ``gate_probability`` for that many directions). A fix beyond the bound disagrees
        with the odometry more than the odometry's drift allows: an alias, not a correction.

        Args:
            fix: A BIM fix (its pose and 6x6 information).

        Returns:
            (squared Mahalanobis distance, chi-square bound); (0, inf) when the fix constrains nothing.
        """
        information = fix.information[np.ix_(FIX_AXES, FIX_AXES)]
        values, vectors = np.linalg.eigh(information)
        seen = vectors[:, values > 1e-9 * max(values.max(), 1e-300)]
        if seen.shape[1] == 0:
            return 0.0, np.inf
        innovation = self._innovation(fix)
        spread = seen.T @ (self.covariance + np.linalg.pinv(information)) @ seen
        distance2 = float(innovation @ seen @ np.linalg.solve(spread, seen.T @ innovation))
        return distance2, float(chi2.ppf(self.gate_probability, seen.shape[1]))

    def _innovation(self, fix: Localization) -> np.ndarray:
        measured, _ = to_planar(fix.pose)
        innovation = measured - self.state
        innovation[3] = wrap(innovation[3])
        return innovation

    def update(self, fix: Localization) -> np.ndarray:
        """Fuse a BIM fix into the estimate. Directions the fix cannot constrain carry no information and are
        left as they were.

        Args:
            fix: A BIM fix (its pose and 6x6 information).

        Returns:
            (4,) the correction applied to (x, y, z, yaw): metres and radians.
        """
        information = fix.information[np.ix_(FIX_AXES, FIX_AXES)]
        innovation = self._innovation(fix)
        posterior = np.linalg.inv(np.linalg.inv(self.covariance) + information)
        correction = posterior @ information @ innovation
        self.state = self.state + correction
        self.state[3] = wrap(self.state[3])
        self.covariance = 0.5 * (posterior + posterior.T)
        return correction


@dataclass(frozen=True)
class StationFix:
    """What one station's frame did to the filter: the ``prior`` (4, 4) it was localized from, the ``fix`` (None
    when localization refused the frame), the ``reason`` a fix was refused or not fused (None when it was), and
    the ``correction`` (4,) applied to the state (zeros when none was)."""

    prior: np.ndarray
    fix: Localization | None
    reason: str | None
    correction: np.ndarray

    @property
    def applied(self) -> bool:
        """True when the fix was fused into the filter."""
        return self.reason is None


def fuse_frame(pose_filter: PoseFilter, frame: Frame, model: BimModel, R_level_camera: np.ndarray,
               up: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 1.0),
               config: LocalizationConfig | None = None) -> StationFix:
    """Localize a frame from the filter's current estimate and fuse the fix; a frame that cannot be localized
    leaves the filter on its odometry, and says why.

    Args:
        pose_filter: The filter; updated in place when the fix is fused.
        frame: The station's RGB-D frame (depth in metres).
        model: The BIM, loaded with geometry.
        R_level_camera: (3,3) the IMU's tilt: camera (OpenCV axes) to the levelled heading frame.
        up: The measured world up, a unit 3-vector.
        config: Localization's settings; None uses the defaults.

    Returns:
        What the frame did: the prior, the fix, why it was refused (None when fused) and the correction.
    """
    prior = from_planar(pose_filter.state, R_level_camera)
    try:
        fix = localize(frame, model, prior, up=up, config=config)
    except LocalizationError as error:
        return StationFix(prior, None, str(error), np.zeros(4))
    distance2, bound = pose_filter.surprise(fix)
    if distance2 > bound:
        return StationFix(prior, fix, f"the fix is {np.sqrt(distance2):.1f} sigma from the odometry's prediction "
                                      f"(gate {np.sqrt(bound):.1f}): rejected as an alias", np.zeros(4))
    return StationFix(prior, fix, None, pose_filter.update(fix))
