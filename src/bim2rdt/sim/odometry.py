"""Simulated legged odometry: what the robot believes it walked, drifting from what it walked.

A quadruped's leg odometry loses 1-3 % of the distance travelled and its heading drifts by degrees over a tour.
Seeded drift: every step's translation is off by ``drift_fraction`` of its length in one body-frame direction
drawn once per run (slip and scale error together), and the heading drifts ``heading_drift_deg_per_10m`` per
10 m walked with a sign drawn once; plus white noise per step (``noise_fraction`` of the step, heading noise per
square-root metre) and a ``turn_noise_fraction`` error on every turn in place. Poses are the planar states of
:mod:`bim2rdt.localization.planar` (x, y, z, yaw).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bim2rdt.localization.planar import between, compose, wrap


@dataclass(frozen=True)
class OdometryDrift:
    """The drift model, seeded per run (see the module docstring). Fractions are of distance, angles degrees."""

    drift_fraction: float = 0.02
    heading_drift_deg_per_10m: float = 1.0
    noise_fraction: float = 0.005
    heading_noise_deg_per_sqrt_m: float = 0.05
    turn_noise_fraction: float = 0.005
    step: float = 0.1  # m: the path is walked in steps this long


@dataclass(frozen=True)
class OdometryReading:
    """One leg's odometry: the measured ``increment`` (forward, left, up m, turn rad) in the heading frame of
    the leg's start, the ``distance`` walked (m, measured) and the angle ``turned`` (rad, absolute sum)."""

    increment: np.ndarray
    distance: float
    turned: float


class SimulatedOdometry:
    """Odometry of a robot walking a true path: :meth:`leg` turns the true states of one leg (start first) into
    the reading the robot's odometry would give. The drift direction and heading-drift sign are drawn once from
    ``seed`` and kept for the whole run, as a real robot's biases are."""

    def __init__(self, seed: int = 0, drift: OdometryDrift = OdometryDrift()):
        self.drift = drift
        self.rng = np.random.default_rng(seed)
        angle = self.rng.uniform(0.0, 2 * np.pi)
        self.bias = drift.drift_fraction * np.array([np.cos(angle), np.sin(angle)])  # per metre, body frame
        self.heading_rate = np.deg2rad(drift.heading_drift_deg_per_10m) / 10.0 * self.rng.choice([-1.0, 1.0])

    def leg(self, true_states: np.ndarray) -> OdometryReading:
        """The reading over true states (K, 4) (x, y, z, yaw), densified to ``step``-metre steps."""
        believed = np.asarray(true_states[0], dtype=float).copy()
        distance = turned = 0.0
        for a, b in zip(true_states[:-1], true_states[1:]):
            for true_step in _steps(np.asarray(a, float), np.asarray(b, float), self.drift.step):
                measured = self._measure(true_step)
                believed = compose(believed, measured)
                distance += float(np.hypot(*measured[:2]))
                turned += abs(float(measured[3]))
        return OdometryReading(between(np.asarray(true_states[0], float), believed), distance, turned)

    def _measure(self, step: np.ndarray) -> np.ndarray:
        """A true step (forward, left, up, turn) as the odometry reports it."""
        length = float(np.hypot(*step[:2]))
        d = self.drift
        noise = self.rng.normal(0.0, 1.0, 4)
        shift = step[:2] + length * self.bias + d.noise_fraction * length * noise[:2]
        turn = (step[3] + self.heading_rate * length + abs(step[3]) * d.turn_noise_fraction * noise[3]
                + np.deg2rad(d.heading_noise_deg_per_sqrt_m) * np.sqrt(length) * noise[2])
        return np.array([shift[0], shift[1], step[2], turn])


def _steps(a: np.ndarray, b: np.ndarray, step: float) -> list[np.ndarray]:
    """True increments from ``a`` to ``b`` in ``step``-metre pieces: turn in place towards b, walk straight,
    then turn in place to b's yaw (how a quadruped goes from station to station)."""
    travel = b[:2] - a[:2]
    length = float(np.linalg.norm(travel))
    if length < 1e-9:
        return [between(a, b)]
    towards = float(np.arctan2(travel[1], travel[0]))
    first = np.array([a[0], a[1], a[2], towards])
    pieces = [between(a, first)]
    count = max(1, int(np.ceil(length / step)))
    walk = np.array([length / count, 0.0, (b[2] - a[2]) / count, 0.0])
    pieces += [walk] * count
    pieces.append(np.array([0.0, 0.0, 0.0, float(wrap(b[3] - towards))]))
    return pieces
