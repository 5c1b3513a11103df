"""Data association: gates, relax-if-few, trimming and Huber weights down-weight planted outliers."""

from __future__ import annotations

import numpy as np

from bim2rdt.registration import matching


def _index(points, normals=None):
    normals = np.tile([0.0, 0.0, 1.0], (len(points), 1)) if normals is None else normals
    return matching.ModelIndex.build(points, normals)


def _plane_with_outliers(rng, outliers=20):
    grid = np.linspace(-1.0, 1.0, 201)
    model = np.c_[np.stack(np.meshgrid(grid, grid), -1).reshape(-1, 2), np.zeros(201 * 201)]
    scene = np.c_[rng.uniform(-0.9, 0.9, (100, 2)), rng.normal(0.0, 0.002, 100)]
    planted = np.c_[rng.uniform(-0.9, 0.9, (outliers, 2)), rng.uniform(0.1, 0.2, outliers)]
    return model, np.vstack([scene, planted])


def test_trimming_drops_planted_outliers_first():
    rng = np.random.default_rng(0)
    model, scene = _plane_with_outliers(rng)
    pairs = matching.match_pairs(_index(model), scene[None], 0.5)
    matching.trim_pairs(pairs, pairs.residual, 20 / 120, 6)
    assert not pairs.valid[0, 100:].any()
    assert pairs.valid[0, :100].sum() == 100


def test_huber_weights_shrink_with_distance_beyond_delta():
    rng = np.random.default_rng(1)
    model, scene = _plane_with_outliers(rng)
    pairs = matching.match_pairs(_index(model), scene[None], 0.5)
    w = matching.huber_weights(pairs, pairs.residual, 0.01)
    assert w[0, 100:].max() < 0.11
    assert np.median(w[0, :100]) == 1.0


def test_pairs_beyond_the_max_distance_and_across_the_normal_gate_are_invalid():
    model = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    model_normals = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    scene = np.array([[0.0, 0.0, 0.05], [1.0, 0.0, 0.05], [5.0, 0.0, 0.0]])[None]
    pairs = matching.match_pairs(_index(model, model_normals), scene, 0.2)
    assert pairs.valid.tolist() == [[True, True, False]]
    scene_normals = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])[None]
    matching.gate_normals(pairs, scene_normals, model_normals, 45.0)
    assert pairs.valid.tolist() == [[True, False, False]]  # unsigned: a flipped normal still passes


def test_relax_if_few_falls_back_to_all_nearest_pairs():
    model = np.random.default_rng(5).normal(0.0, 0.1, (10, 3))
    scene = np.full((1, 8, 3), 3.0)
    index = _index(model)
    pairs = matching.match_pairs(index, scene, 0.5)
    assert not pairs.valid.any()
    matching.relax_if_few(pairs, index, scene, 6, 0.5)
    assert pairs.valid.all() and np.all(np.isfinite(pairs.residual)) and pairs.distance.min() > 2.0


def test_huber_scale_anneals_from_the_pair_distance_to_the_final_delta():
    deltas = [matching.annealed_delta(i, 0.25, 0.01, 6) for i in range(8)]
    assert deltas[0] == 0.25 and deltas[6] == deltas[7] == 0.01
    assert all(a > b for a, b in zip(deltas[:6], deltas[1:7]))


def test_scene_normals_of_a_plane_point_along_its_normal():
    rng = np.random.default_rng(2)
    plane = np.c_[rng.uniform(-1, 1, (200, 2)), np.zeros(200)]
    normals = matching.scene_normals(plane, 8)
    assert np.allclose(np.abs(normals[:, 2]), 1.0, atol=1e-9)
