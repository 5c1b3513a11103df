"""The rigid solve of one step: exact on known transforms, the gravity term is one extra correspondence."""

from __future__ import annotations

import numpy as np

from bim2rdt.registration.so3 import axis_angle, exp_so3, rotation_angle
from bim2rdt.registration.solvers import solve_point_to_plane, solve_point_to_point


def _random_rigid(rng):
    return exp_so3(rng.normal(0.0, 0.8, 3)), rng.normal(0.0, 1.0, 3)


def test_point_to_point_recovers_known_transforms_exactly():
    rng = np.random.default_rng(0)
    for _ in range(5):
        R, t = _random_rigid(rng)
        src = rng.normal(0.0, 0.5, (50, 3))
        dst = src @ R.T + t
        dR, dt = solve_point_to_point(src[None], dst[None], np.ones((1, 50)), np.zeros((1, 3)),
                                      np.array([0.0, 0.0, 1.0]), np.zeros(1))
        assert np.allclose(dR[0], R, atol=1e-9) and np.allclose(dt[0], t, atol=1e-9)


def test_point_to_plane_steps_converge_to_a_known_transform():
    rng = np.random.default_rng(1)
    R, t = exp_so3(np.array([0.05, -0.08, 0.1])), np.array([0.02, -0.03, 0.01])
    dst = rng.normal(0.0, 0.5, (200, 3))
    normals = rng.normal(size=(200, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    src = (dst - t) @ R  # dst = R src + t
    for _ in range(6):
        dR, dt = solve_point_to_plane(src[None], dst[None], normals[None], np.ones((1, 200)), np.zeros((1, 3)),
                                      np.array([0.0, 0.0, 1.0]), np.zeros(1))
        src = src @ dR[0].T + dt[0]
    assert np.allclose(src, dst, atol=1e-9)


def test_gravity_term_equals_adding_weighted_g_model_g_world_to_the_cross_covariance():
    rng = np.random.default_rng(2)
    model = rng.normal(0.0, 0.4, (40, 3))
    world = model @ exp_so3(np.array([0.3, 0.2, -0.5])).T + rng.normal(0.0, 0.05, (40, 3))
    w = rng.uniform(0.2, 1.0, 40)
    g_model, g_world, lam = np.array([0.0, 0.0, 1.0]), np.array([0.1, -0.2, 0.97]), 3.7
    g_world /= np.linalg.norm(g_world)
    dR, _ = solve_point_to_point(model[None], world[None], w[None], g_model[None], g_world, np.array([lam]))
    m_c = model - w @ model / w.sum()
    q_c = world - w @ world / w.sum()
    H = (w[:, None] * m_c).T @ q_c + lam * np.outer(g_model, g_world)
    U, _, Vt = np.linalg.svd(H)
    expected = Vt.T @ np.diag([1, 1, np.sign(np.linalg.det(Vt.T @ U.T))]) @ U.T
    assert np.allclose(dR[0], expected, atol=1e-12)
    without, _ = solve_point_to_point(model[None], world[None], w[None], g_model[None], g_world, np.zeros(1))
    assert np.linalg.norm(dR[0] @ g_model - g_world) < np.linalg.norm(without[0] @ g_model - g_world)


def test_yaw_only_steps_rotate_about_the_given_axis_only():
    rng = np.random.default_rng(3)
    axis = np.array([0.2, 0.1, 0.97])
    axis /= np.linalg.norm(axis)
    src = rng.normal(0.0, 0.5, (80, 3))
    dst = src @ exp_so3(np.array([0.4, -0.3, 0.6])).T
    normals = rng.normal(size=(80, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    for dR, _ in (solve_point_to_point(src[None], dst[None], np.ones((1, 80)), axis[None], axis, np.zeros(1), True),
                  solve_point_to_plane(src[None], dst[None], normals[None], np.ones((1, 80)), axis[None], axis,
                                       np.zeros(1), True)):
        assert np.allclose(dR[0] @ axis, axis, atol=1e-12)
        assert rotation_angle(dR[0]) > 0.05


def test_yaw_only_kabsch_finds_the_exact_yaw():
    rng = np.random.default_rng(4)
    axis = np.array([0.0, 0.0, 1.0])
    src = rng.normal(0.0, 0.5, (30, 3))
    R = axis_angle(axis, np.array(2.5))
    dR, _ = solve_point_to_point(src[None], (src @ R.T)[None], np.ones((1, 30)), axis[None], axis, np.zeros(1), True)
    assert np.allclose(dR[0], R, atol=1e-12)
