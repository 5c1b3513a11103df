"""The speed levers of decision 0035: the direct solve where no direction is degenerate gives the eigen-solve's
step; far points skip the surface patches with the same answer; a search stops once its converged restarts agree
and the running ones are behind."""

from __future__ import annotations

import numpy as np

from bim2rdt.registration import IcpConfig, matching
from bim2rdt.registration import icp
from bim2rdt.registration.solvers import (_FULL_ROTATIONAL, _eigen_solve, _remapped_solve, _unit_scales,
                                          _well_determined)


def _systems(rng, k=12):
    J = rng.normal(size=(k, 40, 6))
    A = np.swapaxes(J, 1, 2) @ J
    A[3, :, 5] = A[3, 5, :] = 0.0  # a direction the data leave free (a deck seen from above)
    A[3, 5, 5] = 1e-12
    return A, rng.normal(size=(k, 6))


def test_the_direct_solve_is_the_eigen_solve_where_every_direction_is_kept():
    A, b = _systems(np.random.default_rng(0))
    scales = _unit_scales(_FULL_ROTATIONAL, A)
    A_s = scales[:, :, None] * A * scales[:, None, :]
    sure = _well_determined(A_s)
    assert not sure[3] and sure[np.arange(12) != 3].all()
    assert np.allclose(_remapped_solve(A, b, scales), _eigen_solve(A_s, b, scales), rtol=1e-9, atol=1e-12)
    assert _remapped_solve(A, b, scales)[3, 5] == 0.0  # the free direction still does not move


def test_far_points_skip_the_patches_with_the_same_answer(crate_model):
    model = matching.ModelIndex.build(*crate_model)
    rng = np.random.default_rng(2)
    points = np.concatenate([crate_model[0][:200] + rng.normal(0.0, 0.004, (200, 3)),
                             rng.uniform(2.0, 3.0, (50, 3))])[rng.permutation(250)]
    distance, index = model.tree.query(points, k=matching.SURFEL_CANDIDATES,
                                       distance_upper_bound=0.03 + model.surfel_radius)
    every_row = matching.nearest_patches_of(model, points, distance, index)
    skipped = matching.nearest_patches(model, points, 0.03)
    far = ~np.isfinite(distance[:, 0])
    assert far.sum() == 50
    assert np.array_equal(skipped.distance, every_row.distance)
    assert np.array_equal(skipped.other_face, every_row.other_face)
    assert np.array_equal(skipped.sample[~far], every_row.sample[~far])


def _state(poses, scores, done):
    restarts = icp._Restarts.start(np.asarray(poses, dtype=float))
    restarts.scores[:] = scores
    restarts.done[:] = done
    return restarts


def test_a_search_stops_once_enough_converged_restarts_agree_and_the_rest_are_behind():
    cfg = IcpConfig(stop_when_agreed=2)
    shifted = np.eye(4)
    shifted[0, 3] = 0.5
    late = cfg.huber_anneal_iterations
    restarts = _state([np.eye(4), np.eye(4), shifted, shifted], [1.0, 1.0, 2.0, 0.9], [True, True, False, False])
    icp.stop_if_agreed(restarts, np.zeros(3), cfg, late)
    assert not restarts.pruned.any()  # a running restart scores lower than the agreed one: it goes on
    restarts.scores[3] = 1.5
    icp.stop_if_agreed(restarts, np.zeros(3), cfg, late - 2)
    assert not restarts.pruned.any()  # not while the Huber scale anneals
    icp.stop_if_agreed(restarts, np.zeros(3), IcpConfig(stop_when_agreed=3), late)
    assert not restarts.pruned.any()  # two agree, three are asked for
    icp.stop_if_agreed(restarts, np.zeros(3), cfg, late)
    assert restarts.pruned.tolist() == [False, False, True, True]
    off = _state([np.eye(4), np.eye(4), shifted], [1.0, 1.0, 2.0], [True, True, False])
    icp.stop_if_agreed(off, np.zeros(3), IcpConfig(stop_when_agreed=0), late)
    assert not off.pruned.any()
