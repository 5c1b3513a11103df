"""Data association: gates, relax-if-few, trimming and Huber weights down-weight planted outliers."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import trimesh

from bim2rdt.registration import matching, sample_model
from bim2rdt.sim.families import FAMILIES, cone_on_plate, sparse_view
from bim2rdt.sim.meshes import wooden_crate


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


def _box_index(count=2000, extents=(0.6, 0.4, 0.5)):
    box = trimesh.creation.box(extents=extents)
    return matching.ModelIndex.build(*sample_model(box, count, seed=1, drop_resting_face=False))


@pytest.mark.parametrize("count, bound", [(2000, 0.0035), (10000, 0.0026)])
def test_a_crate_seen_at_its_true_pose_is_as_far_from_the_surface_as_the_sensor_noise(count, bound):
    """Issue 13: the nearest sample's plane reported ~10 mm for 2 mm noise; the surface distance ~2-3 mm."""
    crate = wooden_crate()
    model = matching.ModelIndex.build(*sample_model(crate, count, seed=1))
    pool = sample_model(crate, 20000, seed=5, drop_resting_face=False)
    spec = dataclasses.replace(FAMILIES["F1"], noise=0.002, occluded_fraction=0.0, elevation_deg=(20.0, 40.0))
    surface, plane = [], []
    for seed in range(4):
        view = sparse_view(crate, pool, 400, spec, np.random.default_rng(seed))
        surface.append(matching.surface_distances(model, view, 0.03))
        plane.append(matching.match_pairs(model, view[None], 0.25).residual[0])
    rms = lambda d: np.sqrt(np.mean(np.concatenate(d)[np.concatenate(d) < 0.03] ** 2))  # noqa: E731
    assert rms(surface) < bound < 1.5 * rms(plane)


def test_a_point_past_a_convex_edge_is_as_far_from_the_surface_as_it_is_past_the_edge():
    model = _box_index()
    beyond = np.array([[0.3 + gap, 0.0, 0.25] for gap in (0.01, 0.02, 0.04)])  # in the top face's plane
    on_top, inside_edge = np.array([[0.1, 0.05, 0.25]]), np.array([[0.29, 0.0, 0.25]])
    distances = matching.surface_distances(model, np.vstack([beyond, on_top, inside_edge]))
    assert distances[:3] == pytest.approx([0.01, 0.02, 0.04], abs=0.002)
    assert distances[3:] == pytest.approx([0.0, 0.0], abs=1e-9)


def test_a_thin_tube_is_not_fattened_by_its_samples_patches():
    tube = trimesh.creation.cylinder(radius=0.0125, height=1.0, sections=12)
    model = matching.ModelIndex.build(*sample_model(tube, 4000, seed=2, drop_resting_face=False))
    beside = np.array([[0.0125 + gap, 0.0, 0.1] for gap in (0.0, 0.01, 0.02)])
    assert matching.surface_distances(model, beside) == pytest.approx([0.0, 0.01, 0.02], abs=0.003)


def test_a_concave_crease_leaves_the_plate_next_to_a_cone_on_the_surface():
    model = matching.ModelIndex.build(*sample_model(cone_on_plate(0.17, 0.68, 0.36)(), 2000, seed=3,
                                                    drop_resting_face=False))
    on_plate = np.array([[0.175, 0.0, 0.03], [0.0, -0.172, 0.03]])  # just outside the cone's foot
    assert matching.surface_distances(model, on_plate) == pytest.approx([0.0, 0.0], abs=0.002)


def test_the_model_index_is_built_once_per_content_and_a_changed_model_gets_its_own():
    points, normals = sample_model(trimesh.creation.box(extents=(0.4, 0.3, 0.2)), 500, seed=4)
    first = matching.ModelIndex.cached(points, normals)
    assert matching.ModelIndex.cached(points.copy(), normals.copy()) is first  # same content, new arrays
    moved = points + [0.0, 0.0, 0.01]
    assert matching.ModelIndex.cached(moved, normals) is not first
    assert np.array_equal(matching.ModelIndex.cached(moved, normals).points, moved)


def test_a_model_differing_only_between_the_checksummed_samples_is_not_taken_for_a_cached_one():
    """The cache key reads every 64th sample; equality is confirmed on all of them (a model with the same key
    replaces the cached one: a rebuild, never a wrong model)."""
    points, normals = sample_model(trimesh.creation.box(extents=(0.4, 0.3, 0.2)), 500, seed=5)
    first = matching.ModelIndex.cached(points, normals)
    nudged, turned = points.copy(), normals.copy()
    nudged[1] += 0.001
    turned[1] = -turned[1]
    assert matching.ModelIndex.cached(nudged, normals).points[1] == pytest.approx(nudged[1])
    assert matching.ModelIndex.cached(points, turned).normals[1] == pytest.approx(turned[1])
    again = matching.ModelIndex.cached(points, normals)
    assert np.array_equal(again.points, points) and np.array_equal(again.normals, normals)


def test_a_cached_model_keeps_its_own_copy_of_the_callers_samples():
    points, normals = sample_model(trimesh.creation.box(extents=(0.5, 0.3, 0.2)), 500, seed=6)
    first = matching.ModelIndex.cached(points, normals)
    points[1] += 0.5  # the caller reuses its array for another model
    assert not np.array_equal(first.points, points)
    again = matching.ModelIndex.cached(points, normals)
    assert again is not first and np.array_equal(again.points, points)


def test_the_lowest_sample_along_any_direction_is_one_of_the_hull_samples():
    """The resting contact searches only the convex hull's samples; along any direction the lowest of those is
    the lowest of all. Flat samples span no volume: then every sample is kept."""
    from bim2rdt.registration.matching import hull_vertices

    rng = np.random.default_rng(0)
    points = rng.normal(size=(5000, 3)) * (0.6, 0.4, 0.2)
    hull = hull_vertices(points)
    assert len(hull) < len(points) // 10
    directions = rng.normal(size=(200, 3))
    lowest_of_hull = hull[np.argmin(points[hull] @ directions.T, axis=0)]
    assert np.array_equal(np.argmin(points @ directions.T, axis=0), lowest_of_hull)
    flat = points.copy()
    flat[:, 2] = 0.0
    assert len(hull_vertices(flat)) == len(flat)


@pytest.mark.parametrize("samples, k, bound", [(1000, 1, 0.05), (1000, 1, np.inf), (1000, 8, 0.1), (6, 8, np.inf),
                                               (6, 8, 0.3), (3, 8, 0.5)])
def test_sample_tree_answers_exactly_what_scipy_answers(samples, k, bound):
    """The fast tree must change no registration: the same neighbours, distances, and misses (inf at index n),
    also when k exceeds the samples (pykdtree itself pads those with 2^32 - 1 and 1e154)."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(samples + k)
    points, queries = rng.random((samples, 3)), rng.random((200, 3))
    ours = matching.SampleTree(points).query(queries, k=k, distance_upper_bound=bound)
    scipy = cKDTree(points).query(queries, k=k, distance_upper_bound=bound)
    np.testing.assert_array_equal(ours[1], scipy[1])
    np.testing.assert_array_equal(ours[0], scipy[0])


@pytest.mark.parametrize("apart_deg, another_face", [(60.0 + 1e-10, False), (60.0, False), (61.0, True)])
def test_patches_exactly_60_degrees_apart_are_one_surface_whatever_the_last_bit(apart_deg, another_face):
    """OTHER_FACE_DEG is 'more than 60 degrees' with a margin: a tube's facets two apart (exactly 60 degrees) must
    not count as another face on one machine and as the same surface on the next (their cosine sits on the
    threshold to the last bit)."""
    grid = np.arange(3) * 0.01
    points = np.stack(np.meshgrid(grid, grid, grid, indexing="ij"), -1).reshape(-1, 3)
    normals = np.tile([1.0, 0.0, 0.0], (len(points), 1))
    turned = np.deg2rad(apart_deg)
    normals[1] = (np.cos(turned), np.sin(turned), 0.0)  # the sample at (0, 0, 0.01): a near neighbour
    patches = matching.nearest_patches(_index(points, normals), np.array([[0.0, 0.002, 0.001]]))
    assert patches.sample[0] == 0
    assert np.isfinite(patches.other_face[0]) == another_face


def test_a_point_as_near_to_two_patches_as_the_last_bit_keeps_the_nearer_sample():
    """Two patches of one face a few ulps apart in height: np.argmin would pick by those bits (which follow the
    CPU's BLAS kernel upstream); the nearest patch is the first candidate within a nanometre of the best."""
    grid = np.arange(5) * 0.01
    points = np.c_[np.stack(np.meshgrid(grid, grid), -1).reshape(-1, 2), np.zeros(25)]
    points[1, 2] = 1e-18  # (0.01, 0): farther from the point than sample 0, and a few ulps nearer in height
    patches = matching.nearest_patches(_index(points), np.array([[0.001, 0.0, 0.001]]))
    assert patches.sample[0] == 0
