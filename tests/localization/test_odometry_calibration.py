"""Online odometry calibration (``localization.calibration``): legs walked with a known bias per metre (a scale
error, a lateral slip, a heading drift bending the walk) give that bias back, and the calibrated odometry predicts
a new leg within millimetres; too few legs, or legs whose errors are random, are not trusted; a direction a view
leaves free is completed from the odometry only when it is precise enough and the estimates before and after
agree."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.localization.calibration import SCANNER_FORWARD, LegError, along_free, calibrate, leg_error
from bim2rdt.localization.global_config import OdometryCalibrationConfig
from bim2rdt.localization.planar import rz

BIAS = (0.02, -0.012, np.deg2rad(0.15), 0.0)
"""along m/m, across m/m, heading rad/m, up m/m: what the odometry misses per metre walked."""


def close(found, expected, tolerances) -> bool:
    """The first three coefficients (along, across, turn) each within its tolerance."""
    return all(abs(f - e) <= t for f, e, t in zip(found[:3], expected[:3], tolerances))


def pose(x: float, y: float, yaw: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = rz(yaw)
    T[:3, 3] = (x, y, 0.4)
    return T


def walked(start: np.ndarray, length: float, turn: float, bias=BIAS, noise: float = 0.0, rng=None,
           turn_noise: float = 0.0, turn_error: float = 0.0):
    """(the odometry's step, the true end): the robot turns ``turn`` rad, walks ``length`` m straight ahead, its
    heading drifting c rad per metre; the odometry sees a straight walk ``bias`` short and no drift, plus random
    errors: ``noise`` m per metre, and ``turn_noise`` rad per radian turned carried across the walk; the turn
    before the walk ``turn_error`` rad more than the odometry saw (the walk and the end's heading turn with it)."""
    a, b, c, _ = bias
    heading = turn + np.arctan2(start[1, 0], start[0, 0])
    u = np.array([np.cos(heading), np.sin(heading)])
    n = np.array([-u[1], u[0]])
    true_end = pose(*(start[:2, 3] + rz(turn_error)[:2, :2] @ u * length), heading + c * length + turn_error)
    # the truth is the odometry's walk plus the bias, so the odometry's walk is the truth less it
    shift = u * (length - a * length) - n * (b * length + c * length**2 / 2)
    if rng is not None:
        shift = shift + rng.normal(0.0, noise * length, 2) + n * rng.normal(0.0, turn_noise * abs(turn)) * length
    odometry_end = pose(*(start[:2, 3] + shift), heading)
    return np.linalg.inv(start) @ odometry_end, true_end


def legs_with(bias=BIAS, count: int = 10, noise: float = 0.001, seed: int = 0, turn_noise: float = 0.0,
              turn_error: float = 0.0) -> list[LegError]:
    rng = np.random.default_rng(seed)
    start, out = pose(1.0, 2.0, 0.3), []
    for _ in range(count):
        turn = rng.uniform(-2.5, 2.5)
        step, end = walked(start, rng.uniform(2.0, 7.0), turn, bias, noise, rng, turn_noise,
                           rng.normal(0.0, turn_error * abs(turn)))
        out.append(leg_error(start, step, end, SCANNER_FORWARD))  # these poses head along their x
        start = end
    return out


def test_known_bias_is_recovered_and_corrects_a_new_leg():
    calibration = calibrate(legs_with())
    assert calibration.valid and calibration.applied and calibration.legs == 10
    assert close(calibration.coefficients, BIAS, (1e-3, 1e-3, np.deg2rad(0.02))), calibration.coefficients
    assert max(calibration.sigma[:2]) < 0.003 < min(calibration.raw_sigma[:2])
    start = pose(5.0, 5.0, 1.0)
    step, truth = walked(start, 6.0, 0.8)
    raw = start @ step
    assert np.linalg.norm(raw[:2, 3] - truth[:2, 3]) > 0.1  # 6 m at 2 % and more: the raw odometry is off
    predicted, covariance = calibration.predict(start, step)
    assert np.linalg.norm(predicted[:2, 3] - truth[:2, 3]) < 0.005
    turn = predicted[:3, :3] @ truth[:3, :3].T
    assert abs(np.arctan2(turn[1, 0], turn[0, 0])) < np.deg2rad(0.05)
    assert np.sqrt(np.linalg.eigvalsh(covariance[:2, :2]).max()) < 0.025


def test_the_error_across_grows_with_the_turn_before_the_walk():
    """Half a degree of heading error per radian turned in place (random): a leg after a big turn is less sure
    across than one walked straight on, and its uncertainty covers what the legs showed."""
    legs = legs_with(count=20, turn_noise=np.deg2rad(0.5), seed=3)
    calibration = calibrate(legs)
    assert calibration.valid and calibration.sigma[3] > 0.003  # s_t, m per metre per radian
    start = pose(0.0, 0.0, 0.0)
    spreads = []
    for turn in (0.0, 2.0):
        step, _ = walked(start, 5.0, turn)
        _, covariance, _ = calibration.displacement(start[:3, :3], step, SCANNER_FORWARD)
        across = np.array([-np.sin(turn), np.cos(turn), 0.0])
        spreads.append(float(np.sqrt(across @ covariance @ across)))
    assert spreads[1] > 2 * spreads[0]
    # 2 rad at 0.5 deg/rad over 5 m is 8.7 cm of error across, 1 sigma: the fit finds about that
    assert 0.04 < spreads[1] < 0.2, spreads


def test_the_heading_error_seen_at_the_end_tells_the_error_across():
    """Each turn before a walk is off by 0.5 % of it (random): the end's fixed heading shows that error, and the
    calibration carries the share made before the walk across it (the turn, walk, turn model's gain)."""
    calibration = calibrate(legs_with(count=20, turn_error=0.005, seed=4))
    assert calibration.turn_noise is not None and calibration.sigma_given_turn[3] < calibration.sigma[3]
    start = pose(0.0, 0.0, 0.0)
    step, truth = walked(start, 5.0, 1.5, turn_error=np.deg2rad(0.6))  # 5 cm across, from the turn
    blind, _ = calibration.predict(start, step, SCANNER_FORWARD)
    seeing, covariance = calibration.predict(start, step, SCANNER_FORWARD, truth[:3, :3])
    assert np.linalg.norm(blind[:2, 3] - truth[:2, 3]) > 0.04
    assert np.linalg.norm(seeing[:2, 3] - truth[:2, 3]) < 0.01
    _, loose = calibration.predict(start, step, SCANNER_FORWARD)
    assert np.trace(covariance) < np.trace(loose)


def test_too_few_legs_are_not_trusted():
    calibration = calibrate(legs_with(count=4))
    assert not calibration.valid and not calibration.applied and "4 legs" in calibration.reason
    start = pose(0.0, 0.0, 0.0)
    step, _ = walked(start, 3.0, 0.0)
    predicted, _ = calibration.predict(start, step)
    np.testing.assert_allclose(predicted, start @ step)  # the raw odometry


def test_random_legs_are_not_calibrated_and_their_spread_is_the_uncertainty():
    calibration = calibrate(legs_with(bias=(0.0, 0.0, 0.0, 0.0), noise=0.03))
    assert calibration.valid and not calibration.applied  # no bias to find: the fit predicts no better
    assert min(calibration.sigma[:2]) > 0.01


def test_one_wrong_leg_is_left_out_of_the_fit():
    legs = legs_with()
    legs[3] = LegError(legs[3].length, legs[3].along + 1.0, legs[3].across - 1.0, 0.0, legs[3].turn + 0.2)
    calibration = calibrate(legs)
    assert close(calibration.coefficients, BIAS, (2e-3, 2e-3, np.deg2rad(0.03))), calibration.coefficients


X = np.array([1.0, 0.0, 0.0])


def test_a_free_direction_is_completed_only_when_the_odometry_is_precise():
    fix = pose(11.0, 2.5, -np.pi / 2)
    truth = fix[:3, 3] + np.array([0.02, 0.0, 0.0])
    fix[:3, 3] += np.array([0.3, 0.0, 0.0])  # the fix does not know where along the wall (x) it stands
    precise = np.diag([0.008, 0.008, 0.005]) ** 2
    completed, sigma, why = along_free(fix, [X], [(truth, precise)], 20)
    assert completed is not None, why
    np.testing.assert_allclose(completed[:3, 3], truth, atol=1e-9)
    np.testing.assert_allclose(completed[:3, :3], fix[:3, :3])  # its heading is the fix's
    assert sigma == pytest.approx(0.008)
    loose = np.diag([0.02, 0.02, 0.005]) ** 2
    refused, _, why = along_free(fix, [X], [(truth, loose)], 20)
    assert refused is None and "more than 5 cm" in why
    few, _, _ = along_free(fix, [X], [(truth, precise * 2.5)], 3)  # 1.3 cm: 3 sigma takes it, t over 3 legs not
    assert few is None and along_free(fix, [X], [(truth, precise * 2.5)], 200)[0] is not None


def test_estimates_before_and_after_are_fused_and_must_agree():
    fix = pose(5.0, 12.5, np.pi / 2)
    forward, back = fix[:3, 3] + [0.01, 0, 0], fix[:3, 3] - [0.01, 0, 0]
    C = np.diag([0.012, 0.012, 0.005]) ** 2
    completed, sigma, _ = along_free(fix, [X], [(forward, C), (back, C)], 20)
    assert completed is not None and np.allclose(completed[:3, 3], fix[:3, 3])
    assert sigma == pytest.approx(0.012 / np.sqrt(2))
    apart, _, why = along_free(fix, [X], [(forward + [0.1, 0, 0], C), (back, C)], 20)
    assert apart is None and "disagrees" in why


def test_the_threshold_is_typed_config():
    strict = OdometryCalibrationConfig(free_tolerance=0.02)
    fix = pose(0.0, 0.0, 0.0)
    C = np.diag([0.008, 0.008, 0.005]) ** 2
    assert along_free(fix, [X], [(fix[:3, 3], C)], 50)[0] is not None
    assert along_free(fix, [X], [(fix[:3, 3], C)], 50, strict)[0] is None
    with pytest.raises(ValueError):
        OdometryCalibrationConfig(min_legs=1)
