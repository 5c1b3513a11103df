"""Online calibration of odometry against a sweep's own confident fixes, and how far the calibrated odometry can
be trusted.

Legged and wheel odometry err mostly systematically: a scale error and a lateral slip per metre walked, and a
heading drift per metre. Each leg between two consecutive frames fixed in every direction measures them: the
odometry's prediction (the start fix composed with the step) against the end fix, in the leg's frame (along the
measured horizontal displacement ``u``, its length ``L``; across it, ``n`` = z x u; up; the turn about up):

    along = a L,   across = b L + c L^2 / 2,   up = v L,   turn = c L

(``c`` rad per metre bends a straight walk: hence ``c L^2 / 2`` across). Each coefficient is a mean of per-metre
ratios over the legs within ``outlier_sigmas`` robust deviations of their median (a slip or a wrong fix is left
out). The fit is validated leave-one-out: every leg predicted by the fit of the others. Those residuals are the
odometry's uncertainty, as the odometry motion model of Probabilistic Robotics (AMCL's ``odom_alpha``) has it: a
leg is a turn in place ``rot1`` (from the sensor's heading to the direction walked), a straight walk, a turn; the
walk's error grows with its length, and the error across it also with the turn before it (a heading error made
turning is carried the whole walk). Per metre: along ``s_a``; across ``sqrt(s_c^2 + (s_t rot1)^2)`` (``s_c``,
``s_t`` >= 0 fitted to the squared residuals, non-negative least squares); up ``s_u``; each times
``max(L, shortest leg fitted)`` (never extrapolated below the legs that measured it), at least ``min_sigma``.
The calibration is applied only when its leave-one-out residuals are smaller than the raw odometry's errors (else
the raw odometry is used, with its own errors as uncertainty); neither is trusted with fewer than ``min_legs``
legs. The sensor's heading is its ``forward`` axis (a camera's optical axis, z; a scanner's x) on the floor: the
sensor is assumed to face the way the robot walks, or to turn with it.

A frame that fixes its heading (a bare wall does) also shows the heading error the leg left, and in the same
model part of it was made before or during the walk, and carried across it. The heading errors of the legs fit
their variance, ``alpha^2 (rot1^2 + rot2^2) + beta^2 L`` (the turns in place and the walk; non-negative least
squares). The error across then moves by the gain ``L (alpha^2 rot1^2 + beta^2 L / 2) / variance`` times the
heading error seen (Gaussian conditioning). This is used only when it predicts the legs' errors across better,
leave-one-out; then its own residuals are the spread (``sigma_given_turn``).

Only fixes and odometry steps are read: no truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize, stats

from bim2rdt.localization.global_config import OdometryCalibrationConfig
from bim2rdt.localization.planar import rz


@dataclass(frozen=True)
class LegError:
    """A leg's odometry error (the end fix less the odometry's prediction): ``length`` L m of horizontal
    displacement, and ``along`` it, ``across`` it (to the left), ``up`` m and ``turn`` rad about up; ``rot1`` rad,
    the turn from the start's heading to the direction walked (as the odometry measured it)."""

    length: float
    along: float
    across: float
    up: float
    turn: float
    rot1: float = 0.0
    rot2: float = 0.0


CAMERA_FORWARD = np.array([0.0, 0.0, 1.0])
"""A camera's heading axis (its optical axis) in its own frame."""
SCANNER_FORWARD = np.array([1.0, 0.0, 0.0])
"""A scanner's heading axis (x, z up) in its own frame."""


def leg_error(start: np.ndarray, step: np.ndarray, end: np.ndarray, forward: np.ndarray = CAMERA_FORWARD
              ) -> LegError:
    """One leg's odometry error, in the leg's frame.

    Args:
        start: T_world_sensor (4, 4) fixed at the leg's start.
        step: The odometry's T_start_end (4, 4).
        end: T_world_sensor (4, 4) fixed at its end.
        forward: The sensor's heading axis in its own frame.

    Returns:
        The error of ``start @ step`` against ``end``.
    """
    moved = start @ step
    d = moved[:3, 3] - start[:3, 3]
    u, n, length = _frame(d)
    error = end[:3, 3] - moved[:3, 3]
    return LegError(length, float(error[:2] @ u), float(error[:2] @ n), float(error[2]), _turn(moved, end),
                    _rot1(start[:3, :3], d, forward), _rot1(end[:3, :3], d, forward))


@dataclass(frozen=True)
class OdometryCalibration:
    """The odometry's calibration and uncertainty from ``legs`` legs (see the module's note). ``coefficients``
    (a, b, c, v): along and across m per metre, turn rad per metre, up m per metre; ``applied`` whether they
    correct the odometry (else the raw odometry is used); ``sigma`` (along, across, up) m per metre of the
    odometry used (leave-one-out); ``raw_sigma`` the raw odometry's; ``shortest`` m, the shortest leg fitted;
    ``valid`` whether enough legs measured it (``reason`` says why not); ``sigma`` also has ``s_t``, across m per
    metre per radian turned before the walk (the module's note). ``turn_noise`` (alpha^2, beta^2) when the
    heading error seen at a leg's end corrects the error across it, and ``sigma_given_turn`` the spread then."""

    legs: int
    coefficients: tuple[float, float, float, float]
    applied: bool
    sigma: tuple[float, float, float, float]
    raw_sigma: tuple[float, float, float, float]
    shortest: float
    valid: bool
    reason: str
    min_sigma: float = 0.005
    turn_noise: tuple[float, float] | None = None
    sigma_given_turn: tuple[float, float, float, float] | None = None

    def displacement(self, R_start: np.ndarray, step: np.ndarray, forward: np.ndarray = CAMERA_FORWARD,
                     R_end: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, float]:
        """The step's displacement in the world, corrected when the calibration is applied, and its covariance.

        Args:
            R_start: World rotation (3, 3) of the sensor at the step's start.
            step: The odometry's T_start_end (4, 4).
            forward: The sensor's heading axis in its own frame.
            R_end: World rotation (3, 3) fixed at the step's end, when known: the heading error it shows tells
                part of the error across the walk (``turn_noise``).

        Returns:
            (displacement (3,) m, its covariance (3, 3) m^2, the turn correction about up, rad).
        """
        d = R_start @ step[:3, 3]
        u, n, length = _frame(d)
        raw, turn = d.copy(), 0.0
        if self.applied:
            a, b, c, v = self.coefficients
            d = d + np.r_[u * a * length + n * (b * length + c * length**2 / 2), v * length]
            turn = c * length
        rot1 = _rot1(R_start, raw, forward)
        sigma = self.sigma
        if self.turn_noise is not None and R_end is not None:
            R_odometry = rz(turn) @ R_start @ step[:3, :3]
            residual = _turn_of(R_end @ R_odometry.T)
            gain = _gain(self.turn_noise, length, rot1, _rot1(R_end, raw, forward))
            d = d + np.r_[n * gain * residual, 0.0]
            sigma = self.sigma_given_turn
        Q = np.array([[u[0], n[0], 0.0], [u[1], n[1], 0.0], [0.0, 0.0, 1.0]])
        scale = max(length, self.shortest)
        s_a, s_c, s_u, s_t = sigma
        across = np.hypot(s_c, s_t * rot1)
        S = np.diag((np.array([s_a, across, s_u]) * scale) ** 2 + self.min_sigma**2)
        return d, Q @ S @ Q.T, float(turn)

    def predict(self, start: np.ndarray, step: np.ndarray, forward: np.ndarray = CAMERA_FORWARD,
                R_end: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Where the odometry puts the end of a leg from a fixed start.

        Args:
            start: T_world_sensor (4, 4) at the step's start.
            step: The odometry's T_start_end (4, 4).
            forward: The sensor's heading axis in its own frame.
            R_end: World rotation (3, 3) fixed at the end, when known (:meth:`displacement`).

        Returns:
            (T_world_sensor (4, 4) at the end, the covariance (3, 3) m^2 of its position).
        """
        d, covariance, turn = self.displacement(start[:3, :3], step, forward, R_end)
        end = start @ step
        end[:3, :3] = rz(turn) @ end[:3, :3]
        end[:3, 3] = start[:3, 3] + d
        return end, covariance

    def to_json(self) -> dict:
        """The calibration as a sweep's output lists it.

        Returns:
            JSON-ready fields (coefficients per metre: along, across m/m, turn deg/m, up m/m; sigmas per metre:
                along, across, up, and across per radian turned before the walk; the turn noise (alpha^2 per
                radian^2 turned, beta^2 rad^2 per metre) and the sigmas given the heading seen, when used).
        """
        a, b, c, v = self.coefficients
        return {"legs": self.legs, "valid": self.valid, "applied": self.applied, "reason": self.reason,
                "along_per_m": round(a, 5), "across_per_m": round(b, 5),
                "turn_deg_per_m": round(float(np.rad2deg(c)), 5),
                "up_per_m": round(v, 5), "sigma_per_m": [round(s, 5) for s in self.sigma],
                "raw_sigma_per_m": [round(s, 5) for s in self.raw_sigma], "shortest_leg_m": round(self.shortest, 3),
                "turn_noise": None if self.turn_noise is None else [float(f"{x:.3g}") for x in self.turn_noise],
                "sigma_given_turn_per_m": None if self.sigma_given_turn is None
                else [round(s, 5) for s in self.sigma_given_turn]}


def calibrate(legs: list[LegError], config: OdometryCalibrationConfig | None = None) -> OdometryCalibration:
    """The calibration from a sweep's legs (see the module's note).

    Args:
        legs: The legs' errors, oldest first (the latest ``max_legs`` of those at least ``min_leg`` long count).
        config: The calibration's settings; None uses the defaults.

    Returns:
        The calibration; not ``valid`` with fewer than ``min_legs`` legs (then nothing is corrected).
    """
    cfg = config or OdometryCalibrationConfig()
    used = [leg for leg in legs if leg.length >= cfg.min_leg][-cfg.max_legs:]
    if len(used) < cfg.min_legs:
        return OdometryCalibration(len(used), (0.0, 0.0, 0.0, 0.0), False, (0.0,) * 4, (0.0,) * 4, 0.0, False,
                                   f"{len(used)} legs between fixes, need {cfg.min_legs}", cfg.min_sigma)
    E = np.array([[leg.length, leg.along, leg.across, leg.up, leg.turn] for leg in used])
    rot1, rot2 = np.array([leg.rot1 for leg in used]), np.array([leg.rot2 for leg in used])
    fits = [_fit(np.delete(E, i, axis=0), cfg) for i in range(len(E))]
    loo = np.array([_residual(E[i], fit) for i, fit in enumerate(fits)])
    calibrated, raw = _spread(loo / E[:, :1], rot1), _spread(E[:, 1:4] / E[:, :1], rot1)
    applied = bool(np.hypot(*_rms(loo / E[:, :1])[:2]) < np.hypot(*_rms(E[:, 1:3] / E[:, :1])))
    coefficients = _fit(E, cfg) if applied else (0.0, 0.0, 0.0, 0.0)
    sigma = calibrated if applied else raw
    reason = "" if applied else "the fit does not predict the legs better than the raw odometry: not applied"
    turn_noise, given_turn = None, None
    if applied:
        turns = E[:, 4] - np.array([fit[2] for fit in fits]) * E[:, 0]  # heading errors left, leave-one-out
        noise = [_turn_noise(np.delete(turns, i), np.delete(E[:, 0], i), np.delete(rot1, i), np.delete(rot2, i))
                 for i in range(len(E))]
        gains = np.array([_gain(k, L, r1, r2) for k, L, r1, r2 in zip(noise, E[:, 0], rot1, rot2)])
        conditioned = loo.copy()
        conditioned[:, 1] -= gains * turns
        if _rms(conditioned[:, 1] / E[:, 0]) < _rms(loo[:, 1] / E[:, 0]):
            turn_noise = _turn_noise(turns, E[:, 0], rot1, rot2)
            given_turn = _spread(conditioned / E[:, :1], rot1)
    return OdometryCalibration(len(used), tuple(float(x) for x in coefficients), applied,
                               tuple(float(s) for s in sigma), tuple(float(s) for s in raw), float(E[:, 0].min()),
                               True, reason, cfg.min_sigma, turn_noise, given_turn)


def _turn_noise(turns: np.ndarray, L: np.ndarray, rot1: np.ndarray, rot2: np.ndarray) -> tuple[float, float]:
    """(alpha^2, beta^2): a leg's heading error has variance alpha^2 (rot1^2 + rot2^2) + beta^2 L (turns in place
    and the walk; non-negative least squares over the legs' heading errors ``turns``, rad)."""
    (alpha2, beta2), _ = optimize.nnls(np.c_[rot1**2 + rot2**2, L], turns**2)
    return float(alpha2), float(beta2)


def _gain(noise: tuple[float, float], L: float, rot1: float, rot2: float) -> float:
    """m across per radian of heading error seen at a leg's end: the share of that error made before or during
    the walk (its covariance with the error across over its variance, for the turn, walk, turn model)."""
    alpha2, beta2 = noise
    variance = alpha2 * (rot1**2 + rot2**2) + beta2 * L
    if variance <= 0.0:
        return 0.0
    return float(L * (alpha2 * rot1**2 + beta2 * L / 2) / variance)


def _fit(E: np.ndarray, cfg: OdometryCalibrationConfig) -> tuple[float, float, float, float]:
    """(a, b, c, v) from rows (L, along, across, up, turn)."""
    L = E[:, 0]
    c = _robust_mean(E[:, 4] / L, cfg.outlier_sigmas)
    a = _robust_mean(E[:, 1] / L, cfg.outlier_sigmas)
    b = _robust_mean((E[:, 2] - c * L**2 / 2) / L, cfg.outlier_sigmas)
    v = _robust_mean(E[:, 3] / L, cfg.outlier_sigmas)
    return a, b, c, v


def _residual(row: np.ndarray, coefficients: tuple[float, float, float, float]) -> np.ndarray:
    """(along, across, up) m of one leg's error left by the coefficients."""
    L, along, across, up, _ = row
    a, b, c, v = coefficients
    return np.array([along - a * L, across - b * L - c * L**2 / 2, up - v * L])


def _robust_mean(x: np.ndarray, sigmas: float) -> float:
    """The mean of the values within ``sigmas`` robust deviations (1.4826 MAD, at least 1e-4) of their median."""
    median = float(np.median(x))
    spread = max(1.4826 * float(np.median(np.abs(x - median))), 1e-4)
    return float(np.mean(x[np.abs(x - median) <= sigmas * spread]))


def _rms(x: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean(x**2, axis=0))


def _spread(per_metre: np.ndarray, rot1: np.ndarray) -> tuple[float, float, float, float]:
    """(s_a, s_c, s_u, s_t) from residuals per metre (along, across, up) and each leg's turn before its walk:
    across^2 = s_c^2 + (s_t rot1)^2 by non-negative least squares."""
    s_a, _, s_u = _rms(per_metre)
    (c2, t2), _ = optimize.nnls(np.c_[np.ones_like(rot1), rot1**2], per_metre[:, 1] ** 2)
    return float(s_a), float(np.sqrt(c2)), float(s_u), float(np.sqrt(t2))


def _rot1(R_start: np.ndarray, d: np.ndarray, forward: np.ndarray) -> float:
    """The turn (rad, absolute) from the sensor's heading to the horizontal displacement ``d`` (0 when none)."""
    ahead = R_start @ forward
    if np.hypot(d[0], d[1]) < 1e-9 or np.hypot(ahead[0], ahead[1]) < 1e-9:
        return 0.0
    return float(abs(np.arctan2(ahead[0] * d[1] - ahead[1] * d[0], ahead[0] * d[0] + ahead[1] * d[1])))


def _frame(d: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """(u, n, L): the horizontal unit along a displacement, to its left, and its length (u = x when none)."""
    length = float(np.hypot(d[0], d[1]))
    u = d[:2] / length if length > 1e-9 else np.array([1.0, 0.0])
    return u, np.array([-u[1], u[0]]), length


def _turn(a: np.ndarray, b: np.ndarray) -> float:
    """The turn about world z from pose a to pose b, rad."""
    return _turn_of(b[:3, :3] @ a[:3, :3].T)


def _turn_of(R: np.ndarray) -> float:
    """The turn of rotation R about world z, rad."""
    return float(np.arctan2(R[1, 0] - R[0, 1], R[0, 0] + R[1, 1]))


def along_free(pose: np.ndarray, free: list[np.ndarray], estimates: list[tuple[np.ndarray, np.ndarray]],
               legs: int, config: OdometryCalibrationConfig | None = None) -> tuple[np.ndarray | None, float, str]:
    """A fix that leaves directions free, completed along them by the odometry's estimates of its position.

    The estimates (from the fix before, carried forward; from the fix after, carried back) are fused by their
    information; they must agree along the free directions within ``sigmas`` of their spread, and the fused
    standard deviation along every free direction times ``sigmas`` must be within ``free_tolerance``. The
    deviations were measured on ``legs`` legs only: ``sigmas`` is widened to the Student-t quantile of the same
    coverage with that many degrees of freedom (3 sigma: 5.0 with 7 legs, 3.6 with 20).

    Args:
        pose: The fix's T_world_sensor (4, 4): its heading and fixed directions are kept.
        free: Unit world directions (3,) the fix's view leaves free.
        estimates: (position (3,) m, covariance (3, 3) m^2) of the sensor by the odometry, one or more.
        legs: How many legs the covariances were measured on.
        config: The calibration's settings (``sigmas``, ``free_tolerance``); None uses the defaults.

    Returns:
        (the completed pose, or None when the odometry is not precise enough or the estimates disagree; the
            largest standard deviation along a free direction, m; why not taken).
    """
    cfg = config or OdometryCalibrationConfig()
    if not estimates or not free:
        return None, float("inf"), "no odometry estimate"
    B = np.linalg.qr(np.array(free, dtype=np.float64).T)[0]
    k = float(stats.t.ppf(stats.norm.cdf(cfg.sigmas), max(legs, 1)))
    if len(estimates) == 2:
        (x_f, C_f), (x_b, C_b) = estimates
        gap = B.T @ (x_f - x_b)
        if float(gap @ np.linalg.solve(B.T @ (C_f + C_b) @ B, gap)) > k**2:
            return None, float("inf"), (f"the odometry from the fixes before and after disagrees by "
                                        f"{100 * np.linalg.norm(gap):.1f} cm along the free direction")
    information = sum(np.linalg.inv(C) for _, C in estimates)
    covariance = np.linalg.inv(information)
    position = covariance @ sum(np.linalg.inv(C) @ x for x, C in estimates)
    sigma = float(np.sqrt(np.linalg.eigvalsh(B.T @ covariance @ B).max()))
    if k * sigma > cfg.free_tolerance:
        return None, sigma, (f"the odometry puts it within {100 * k * sigma:.1f} cm ({k:.1f} sigma over {legs} "
                             f"legs) along the free direction, more than {100 * cfg.free_tolerance:.0f} cm")
    out = np.array(pose, dtype=np.float64)
    out[:3, 3] = out[:3, 3] + B @ (B.T @ (position - out[:3, 3]))
    return out, sigma, ""
