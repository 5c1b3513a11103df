"""Simulated legged odometry drifts as specified: 2 % of the distance, 1 degree of heading per 10 m, plus noise."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.localization.planar import compose
from bim2rdt.sim.odometry import OdometryDrift, SimulatedOdometry

STRAIGHT = np.array([[0.0, 0.0, 1.1, 0.0], [20.0, 0.0, 1.1, 0.0]])


def test_a_straight_walk_drifts_two_percent_and_one_degree_per_ten_metres():
    reading = SimulatedOdometry(seed=3, drift=OdometryDrift(noise_fraction=0.0, heading_noise_deg_per_sqrt_m=0.0,
                                                             turn_noise_fraction=0.0)).leg(STRAIGHT)
    believed = compose(STRAIGHT[0], reading.increment)
    assert abs(np.rad2deg(believed[3])) == pytest.approx(2.0, rel=1e-6)  # 1 deg per 10 m over 20 m
    assert reading.distance == pytest.approx(20.0, abs=0.4 + 1e-9)
    # the translation bias alone is 2 % of 20 m; the heading drift bends the path on top of it
    assert 0.2 < np.linalg.norm(believed[:2] - STRAIGHT[1, :2]) < 0.4 + 20.0 * np.deg2rad(1.0)


def test_noise_scatters_around_the_drift_and_runs_are_reproducible_per_seed():
    ends = [compose(STRAIGHT[0], SimulatedOdometry(seed=s).leg(STRAIGHT).increment) for s in range(20)]
    errors = [np.linalg.norm(e[:2] - STRAIGHT[1, :2]) for e in ends]
    assert 0.2 < np.median(errors) < 0.8
    assert len({round(float(e), 6) for e in errors}) == 20  # each seed drifts its own way
    again = SimulatedOdometry(seed=4).leg(STRAIGHT).increment
    assert again == pytest.approx(SimulatedOdometry(seed=4).leg(STRAIGHT).increment)


def test_a_leg_turns_in_place_walks_and_turns_to_the_stations_heading():
    leg = np.array([[0.0, 0.0, 1.1, 0.0], [0.0, 5.0, 1.1, 3.0]])
    reading = SimulatedOdometry(seed=0, drift=OdometryDrift(drift_fraction=0.0, heading_drift_deg_per_10m=0.0,
                                                            noise_fraction=0.0, heading_noise_deg_per_sqrt_m=0.0,
                                                            turn_noise_fraction=0.0)).leg(leg)
    assert compose(leg[0], reading.increment) == pytest.approx(leg[1], abs=1e-9)
    assert reading.turned == pytest.approx(np.pi / 2 + (3.0 - np.pi / 2))
    assert reading.distance == pytest.approx(5.0)
