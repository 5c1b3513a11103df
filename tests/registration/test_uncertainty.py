"""Pose covariance and unobservable directions: what a view pins down and what it cannot."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from bim2rdt.registration import IcpConfig, register, sample_model
from bim2rdt.registration.uncertainty import POSE_PARAMETERS, least_squares_information, split_information
from bim2rdt.sim.families import cylinder

BOX = trimesh.creation.box(extents=(0.6, 0.4, 0.5), transform=trimesh.transformations.translation_matrix((0, 0, 0.25)))
ONE_RESTART = IcpConfig(restarts=1)


@pytest.fixture(scope="module")
def box_model():
    return sample_model(BOX, 10000, seed=1, drop_resting_face=False)


def _faces(*masks, count=300, noise=0.003, seed=0):
    """Noisy surface points of the box on the faces selected by ``masks`` (functions of (N, 3) points)."""
    points, _ = sample_model(BOX, 20000, seed=seed + 3, drop_resting_face=False)
    keep = np.zeros(len(points), dtype=bool)
    for mask in masks:
        keep |= mask(points)
    chosen = points[keep][:count]
    return chosen + np.random.default_rng(seed).normal(0.0, noise, chosen.shape)


def front(p):
    return np.isclose(p[:, 0], 0.3)


def side(p):
    return np.isclose(p[:, 1], 0.2)


def top(p):
    return np.isclose(p[:, 2], 0.5)


def test_a_box_seen_on_one_face_says_the_directions_in_that_face_are_unconstrained(box_model):
    """Issue 13: from its true pose with one restart a box seen on its +x face slides along that face; the
    result says so: both in-face translations (y, z) are unobservable, the face's normal (x) is not."""
    result = register(*box_model, _faces(front), np.eye(4), config=ONE_RESTART)
    free = result.uncertainty.translation_directions()
    assert len(free) == 2 and not result.uncertainty.well_constrained
    assert np.allclose(np.abs(free[:, 0]), 0.0, atol=0.1)  # both lie in the face (perpendicular to x)
    assert np.linalg.matrix_rank(free[:, 1:], tol=0.5) == 2  # and span it
    assert np.sqrt(result.covariance[3, 3]) < 0.01 < np.sqrt(min(result.covariance[4, 4], result.covariance[5, 5]))


def test_the_slab_pins_the_height_a_view_of_one_face_leaves_open(box_model):
    result = register(*box_model, _faces(front), np.eye(4), config=ONE_RESTART, support_height=0.0)
    free = result.uncertainty.translation_directions()
    assert len(free) == 1 and abs(free[0, 1]) > 0.95  # only along y is the box still free


def test_a_box_seen_on_three_faces_is_well_constrained_to_millimetres(box_model):
    result = register(*box_model, _faces(front, side, top), np.eye(4), config=ONE_RESTART)
    assert result.uncertainty.well_constrained and result.unobservable.shape == (0, 6)
    stds = np.sqrt(np.diag(result.covariance))
    assert np.all(stds[3:] < 0.005) and np.all(stds[:3] < np.deg2rad(0.5))
    assert np.all(np.linalg.eigvalsh(result.covariance) > 0.0)


def test_a_drum_cannot_be_turned_about_its_own_axis_by_any_view():
    drum = cylinder(0.29, 0.88)()
    model = sample_model(drum, 10000, seed=2, drop_resting_face=False)
    points, _ = sample_model(drum, 20000, seed=4, drop_resting_face=False)
    view = points[(points[:, 0] > 0.05) | (points[:, 2] > 0.87)][:400]
    result = register(*model, view + np.random.default_rng(1).normal(0.0, 0.003, view.shape), np.eye(4),
                      config=ONE_RESTART)
    axes = result.uncertainty.rotation_axes()
    assert len(axes) == 1 and abs(axes[0, 2]) > 0.99 and len(result.uncertainty.translation_directions()) == 0


def test_the_covariance_of_a_least_squares_fit_matches_the_scatter_of_its_estimates():
    """The reusable part: for a linear model y = a + b x with noise sigma, sigma^2 (J^T J)^-1 is the
    covariance of the estimates (checked against 2,000 noisy refits)."""
    rng = np.random.default_rng(7)
    x = np.linspace(-1.0, 1.0, 40)
    J = np.c_[np.ones_like(x), x]
    fits = [np.linalg.lstsq(J, 0.3 + 0.5 * x + rng.normal(0.0, 0.02, x.size), rcond=None)[0] for _ in range(2000)]
    information = least_squares_information(J, np.ones_like(x), 0.02)
    covariance, weak, _ = split_information(information, np.ones(2), 0.01, reference=40 / 0.02**2)
    assert weak.shape == (0, 2)
    assert np.allclose(covariance, np.cov(np.array(fits).T), rtol=0.1, atol=1e-6)
    assert np.allclose(covariance @ information, np.eye(2), atol=1e-9)


def test_weak_directions_are_the_ones_the_residuals_do_not_see_and_get_the_weak_variance():
    rng = np.random.default_rng(8)
    J = np.c_[rng.normal(size=(50, 2)), np.zeros(50), 0.001 * rng.normal(size=50)]
    information = least_squares_information(J, np.ones(50), 1.0)
    covariance, directions, strength = split_information(information, np.ones(4), 0.01, reference=50.0,
                                                         weak_variance=4.0)
    assert directions.shape == (2, 4) and np.all(strength[:2] < 1e-4) and np.all(strength[2:] > 0.5)
    assert np.allclose(np.abs(directions[:, :2]), 0.0, atol=1e-3)  # parameters 3 and 4, nothing else
    assert np.allclose(np.diag(covariance)[2:], 4.0, rtol=1e-3) and np.all(np.diag(covariance)[:2] < 0.1)
    assert POSE_PARAMETERS == ("rx", "ry", "rz", "tx", "ty", "tz")
