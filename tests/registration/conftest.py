"""Fixtures for registration tests: a crate's surface samples and a partial, noisy view of it."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.registration import sample_model
from bim2rdt.registration.so3 import axis_angle
from bim2rdt.sim.meshes import wooden_crate


def pose(yaw_rad: float = 0.0, tilt_rad: float = 0.0, translation=(0.0, 0.0, 0.0)) -> np.ndarray:
    """T_world_model: tilt about world x, then yaw about world z, then translate."""
    T = np.eye(4)
    T[:3, :3] = axis_angle(np.array([0.0, 0.0, 1.0]), np.array(yaw_rad)) @ axis_angle(
        np.array([1.0, 0.0, 0.0]), np.array(tilt_rad))
    T[:3, 3] = translation
    return T


@pytest.fixture(scope="module")
def crate_model():
    return sample_model(wooden_crate(), 2000, seed=1)


@pytest.fixture(scope="module")
def crate_view():
    """Two visible faces and the lid of the crate (x > -0.3, y < 0.2 in the body frame), 2 mm noise."""
    points, _ = sample_model(wooden_crate(), 4000, seed=7)
    visible = points[(points[:, 0] > -0.3) & (points[:, 1] < 0.2)][:600]
    return visible + np.random.default_rng(3).normal(0.0, 0.002, visible.shape)


def place(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ T[:3, :3].T + T[:3, 3]


@pytest.fixture
def make_pose():
    return pose


@pytest.fixture
def placed():
    return place
