"""The compiled ICP step (decision 0040) is the numpy step: the same pairs, trimming, weights, gravity term and
solve to round-off, and so the same registrations."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.frames import UP
from bim2rdt.registration import IcpConfig, icp, kernels, matching, register
from bim2rdt.registration.solvers import DEGENERATE_RATIO, SOLVERS, gravity_weight, solve_system
from bim2rdt.registration.validation import validate_problem


def _numpy_step(T, problem, model, cfg, delta, stride, bias, normals_world=None, yaw_only=False):
    """:func:`icp._iterate`'s numpy path up to the step: (dR, dt, scores)."""
    scene_body, pairs, w = icp._weighted_pairs(icp.invert_poses(T), problem, model, normals_world, cfg, delta,
                                               stride)
    dst, normals = pairs.samples, pairs.normals
    up_body = np.einsum("kji,j->ki", T[:, :3, :3], problem.up_world)
    lam = gravity_weight(dst, w, bias * cfg.gravity_gamma0)
    if problem.support_height is not None:
        scene_body, dst, normals, w = icp._with_contact_pair(T, up_body, problem, model.extreme_points,
                                                             cfg.support_weight, (scene_body, dst, normals, w))
    dR, dt = SOLVERS["point_to_plane"].step(scene_body, dst, normals, w, up_body, UP, lam, yaw_only)
    return dR, dt, matching.truncated_score(pairs, cfg.score_distance)


@pytest.fixture
def cluttered_problem(crate_model, crate_view, make_pose, placed):
    """The crate's view, 8 degrees tilted and off by 5 cm, with 60 clutter points (trimming and Huber act)."""
    rng = np.random.default_rng(5)
    scene = np.concatenate([placed(make_pose(0.3, 0.0, (1.0, 2.0, 0.0)), crate_view),
                            rng.uniform((0.4, 1.4, -0.1), (1.6, 2.6, 0.8), (60, 3))])
    init = make_pose(0.45, np.deg2rad(8.0), (1.03, 2.04, 0.02))
    return validate_problem(*crate_model, scene, init, UP, 0.6, 0.0)


@pytest.mark.parametrize("delta, stride", [(0.25, 2), (0.05, 2), (0.01, 1)])
def test_the_compiled_step_is_the_numpy_step(crate_model, cluttered_problem, delta, stride):
    cfg = IcpConfig()
    model = matching.ModelIndex.build(*crate_model)
    starts = icp._restart_starts(cluttered_problem, model, cfg, False)
    bias = np.where(np.arange(len(starts)) % 2 == 0, 0.6, 0.0)  # two searches batched, as the prior-free pass
    compiled = icp._compiled_step(starts, cluttered_problem, model, cfg, delta, stride, bias, False)
    expected = _numpy_step(starts, cluttered_problem, model, cfg, delta, stride, bias)
    for got, want in zip(compiled, expected):
        assert np.allclose(got, want, rtol=1e-9, atol=1e-12)
    assert not np.allclose(expected[1][0], expected[1][1])  # the restarts' steps differ: a real comparison


@pytest.mark.parametrize("yaw_only", [True, False])
def test_the_compiled_step_with_the_normal_gate_is_the_numpy_step(crate_model, cluttered_problem, yaw_only):
    """The localizer's registrations gate pairs by their normals (decision 0050: now compiled too): the gated
    step and score are the numpy path's, and the gate does drop pairs here (a 20 degree gate on a tilted crate
    and its clutter)."""
    cfg = IcpConfig(normal_gate_deg=20.0)
    model = matching.ModelIndex.build(*crate_model)
    normals = matching.scene_normals(cluttered_problem.scene_pts_world, cfg.scene_normal_neighbours)
    starts = icp._restart_starts(cluttered_problem, model, cfg, yaw_only)[:4]
    for delta, stride in [(0.25, 2), (0.01, 1)]:
        compiled = icp._compiled_step(starts, cluttered_problem, model, cfg, delta, stride, 0.0, yaw_only, None,
                                      normals)
        expected = _numpy_step(starts, cluttered_problem, model, cfg, delta, stride, 0.0, normals, yaw_only)
        for got, want in zip(compiled, expected):
            assert np.allclose(got, want, rtol=1e-9, atol=1e-12)
        ungated = icp._compiled_step(starts, cluttered_problem, model, cfg, delta, stride, 0.0, yaw_only, None)
        assert not np.allclose(ungated[1], compiled[1])  # the gate changed the step: a real comparison


def test_the_compiled_solve_is_the_remapped_solve_with_a_degenerate_system():
    rng = np.random.default_rng(0)
    J = rng.normal(size=(6, 40, 6))
    A = np.swapaxes(J, 1, 2) @ J
    A[2, :, 5] = A[2, 5, :] = 0.0  # a direction the data leave free (a deck seen from above)
    A[2, 5, 5] = 1e-12
    b = rng.normal(size=(6, 6)) * 1e-3
    dR, dt = kernels.solve_steps(A, b, DEGENERATE_RATIO)
    want_R, want_t = solve_system(A, b, np.tile(UP, (6, 1)), False)
    assert np.allclose(dR, want_R, atol=1e-12) and np.allclose(dt, want_t, atol=1e-12)
    assert dt[2, 2] == 0.0  # the free direction does not move


def test_a_registration_is_the_same_with_the_numpy_step(crate_model, cluttered_problem, monkeypatch):
    p = cluttered_problem
    args = (*crate_model, p.scene_pts_world, p.T_world_model_init, UP, 0.6)
    compiled = register(*args, support_height=0.0)
    monkeypatch.setattr(icp, "_compiled_step", lambda *a, **k: None)  # every iteration on the numpy path
    numpy_path = register(*args, support_height=0.0)
    assert np.allclose(compiled.pose, numpy_path.pose, atol=1e-9)
    assert compiled.total_iterations == numpy_path.total_iterations
    assert compiled.restart == numpy_path.restart


def test_composed_steps_are_the_pose_times_the_inverse_step():
    rng = np.random.default_rng(4)
    from bim2rdt.registration.so3 import axis_angle, invert_poses, rotation_angle

    T = np.tile(np.eye(4), (5, 1, 1))
    T[:, :3, :3] = axis_angle(rng.normal(size=(5, 3)) / np.sqrt(3.0), rng.uniform(0.0, 3.0, 5))
    T[:, :3, 3] = rng.normal(size=(5, 3))
    dR = axis_angle(np.tile([0.0, 0.6, 0.8], (5, 1)), np.array([0.0, 1e-4, 0.02, 0.5, 3.0]))
    dt = rng.normal(size=(5, 3)) * 0.01
    step = np.tile(np.eye(4), (5, 1, 1))
    step[:, :3, :3], step[:, :3, 3] = dR, dt
    poses, turned, moved = kernels.compose_steps(T, dR, dt)
    assert np.allclose(poses, T @ invert_poses(step), atol=1e-14)
    assert np.allclose(turned, rotation_angle(dR), atol=1e-7) and np.allclose(moved, np.linalg.norm(dt, axis=1))


def test_verify_imports_without_numba_and_load_kernels_brings_its_machine_code_in():
    """``import bim2rdt.verify`` leaves numba out (its import is ~0.2 s); :func:`load_kernels` (verify's setup)
    loads it and each kernel's machine code for both of verify's paths, so a later registration compiles or
    loads nothing: the dispatchers' signatures do not grow."""
    import subprocess
    import sys

    code = ("import sys, numpy as np, bim2rdt.verify\n"
            "assert 'numba' not in sys.modules\n"
            "from bim2rdt.registration import load_kernels, register, kernels\n"
            "load_kernels()\n"
            "names = ('body_points', 'pair_residuals', 'neighbour_scatter', 'smallest_axes', 'any_within',\n"
            "         'plane_steps', 'settle_steps', 'stop_agreed', 'warm_nearest', 'remember_nearest',\n"
            "         'nearest_patches', 'in_range', 'cube_means', 'hit_depths')\n"
            "loaded = {n: len(getattr(kernels, n).signatures) for n in names}\n"
            "assert all(loaded.values()), loaded\n"
            "rng = np.random.default_rng(1)\n"
            "p = rng.uniform(-0.5, 0.5, (400, 3)); n = p / np.linalg.norm(p, axis=1)[:, None]\n"
            "register(p, n, p[:250] + 0.01, yaw_only=True, support_height=-0.5)\n"
            "register(p, n, p[:250] + 0.01, upright_bias=0.5)\n"
            "assert loaded == {n: len(getattr(kernels, n).signatures) for n in names}\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]


@pytest.mark.parametrize("k", [3, 8, 12, 16, 21])
def test_neighbour_scatter_is_numpys_mean_and_einsum_bit_for_bit(k):
    """The scene and scan normals' scatter: compiled, the same floats as the numpy expression it replaced (so the
    normals, and every pose that reads them, are unchanged)."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(k)
    points = np.concatenate([rng.normal(0.0, 1.0, (700, 3)) * [2.0, 1.0, 0.05], rng.uniform(-3, 3, (100, 3))])
    _, index = cKDTree(points).query(points, k=k)
    local = points[index] - points[index].mean(axis=1, keepdims=True)
    want = np.einsum("nki,nkj->nij", local, local)
    got = kernels.neighbour_scatter(points, index)
    assert got.shape == (800, 3, 3) and np.array_equal(got, want)


@pytest.mark.parametrize("spread", [(2.0, 1.0, 0.05), (1.0, 1.0, 0.01), (3.0, 0.05, 0.04), (1.0, 1.0, 1.0)])
def test_the_closed_form_axes_are_eighs(spread):
    """A cloud's normals (a slab, a disc, a rod, a ball): the eigenvalues and the smallest one's axis in closed
    form are ``np.linalg.eigh``'s to round-off (the axis up to its sign, as much as the gap to the next
    eigenvalue allows), and each axis is a unit eigenvector of its matrix."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(len(str(spread)))
    points = rng.normal(0.0, 1.0, (1500, 3)) * spread
    _, index = cKDTree(points).query(points, k=16)
    scatter = kernels.neighbour_scatter(points, index)
    values, axes = matching.smallest_axes(scatter)
    want_values, want_vectors = np.linalg.eigh(scatter)
    top = want_values[:, 2:]
    assert np.all(np.abs(values - want_values) <= 1e-12 * top)  # a near-double pair: ~1e-13 (a rod's cross-section)
    assert np.allclose(np.linalg.norm(axes, axis=1), 1.0, atol=1e-14)
    residual = np.linalg.norm(np.einsum("nij,nj->ni", scatter, axes) - values[:, :1] * axes, axis=1)
    assert np.all(residual <= 1e-12 * top[:, 0])
    gap = (want_values[:, 1] - want_values[:, 0]) / top[:, 0]
    sine = np.linalg.norm(np.cross(axes, want_vectors[:, :, 0]), axis=1)
    assert np.all(sine * gap <= 1e-12) and np.all(sine[gap > 0.1] <= 1e-13)  # an axis is as sure as its gap


def test_the_closed_form_axes_of_special_matrices():
    """Diagonal (sorted as eigh sorts; the smallest's own axis), zero (LAPACK's first axis), a double smallest
    eigenvalue (any unit vector of its plane) and a double largest one: eigenvalues to round-off, unit
    eigenvectors."""
    rng = np.random.default_rng(3)
    turns = np.linalg.qr(rng.normal(size=(200, 3, 3)))[0]
    for spectrum in ([0.0, 1.0, 2.0], [1e-9, 1.0, 1.0], [0.0, 0.0, 1.0], [2.0, 2.0, 2.0], [5.0, 1e-3, 1e-3]):
        A = turns @ np.diag(spectrum) @ np.swapaxes(turns, 1, 2)
        values, axes = matching.smallest_axes(A)
        assert np.allclose(values, np.sort(spectrum), atol=1e-7)
        assert np.allclose(np.einsum("nij,nj->ni", A, axes), values[:, :1] * axes, atol=1e-7)
        assert np.allclose(np.linalg.norm(axes, axis=1), 1.0)
    values, axes = matching.smallest_axes(np.stack([np.diag([3.0, 1.0, 2.0]), np.zeros((3, 3))]))
    assert values.tolist() == [[1.0, 2.0, 3.0], [0.0, 0.0, 0.0]] and axes.tolist() == [[0, 1, 0], [1, 0, 0]]


def test_the_compiled_yaw_solve_is_the_projected_remapped_solve():
    """The yaw-only step (turn about each restart's up, three translations) compiled: ``solve_system``'s with
    ``yaw_only`` to round-off, for well-posed systems (Cholesky) and one whose translation along a wall is free
    (the eigen-directions)."""
    rng = np.random.default_rng(2)
    J = rng.normal(size=(6, 40, 6))
    A = np.swapaxes(J, 1, 2) @ J
    A[4, :, 3] = A[4, 3, :] = 0.0  # x free
    A[4, 3, 3] = 1e-13
    b = rng.normal(size=(6, 6)) * 1e-3
    up = rng.normal(size=(6, 3))
    up /= np.linalg.norm(up, axis=1)[:, None]
    dR, dt = kernels.yaw_steps(A, b, up, DEGENERATE_RATIO)
    want_R, want_t = solve_system(A, b, up, True)
    assert np.allclose(dR, want_R, atol=1e-12) and np.allclose(dt, want_t, atol=1e-12)
    assert np.allclose(np.einsum("kij,kj->ki", dR, up), up, atol=1e-14)  # a turn about the up only
    assert abs(dt[4, 0]) < 1e-12 and not np.allclose(want_R, np.eye(3))


def test_the_compiled_hit_depths_are_the_einsum_formula():
    """The structure's and the permanent map's ray casts: t = n . (v0 - origin) / n . d of each ray's first face
    and that face's normal, as the numpy expression gives them (to round-off; numpy's einsum sums the three
    products in an order of its own), NaN and zeros where a ray hits nothing; on a turned sphere, so no normal
    lies along an axis."""
    import trimesh

    from bim2rdt.perception.background import hit_depths

    rng = np.random.default_rng(4)
    mesh = trimesh.creation.icosphere(subdivisions=2, radius=1.5)
    mesh.apply_transform(trimesh.transformations.random_rotation_matrix(rng.random(3)))
    origin = np.array([0.1, -0.2, 0.05])
    directions = rng.normal(size=(3000, 3))
    face = mesh.ray.intersects_first(np.broadcast_to(origin, directions.shape), directions)
    face[::7] = -1  # some rays hit nothing
    t, normals = hit_depths(mesh, face, origin, directions)
    hit = face >= 0
    want_normals = mesh.face_normals[face[hit]]
    corner = mesh.vertices[mesh.faces[face[hit], 0]]
    want = np.einsum("ni,ni->n", want_normals, corner - origin) / np.einsum("ni,ni->n", want_normals, directions[hit])
    assert np.array_equal(np.isnan(t), ~hit) and np.allclose(t[hit], want, rtol=1e-13, atol=0.0)
    assert np.array_equal(normals[hit], want_normals) and not normals[~hit].any()
    points = origin + directions[hit] * t[hit, None]
    assert np.allclose(np.linalg.norm(points, axis=1), 1.5, atol=0.1)  # on the sphere's facets


@pytest.mark.parametrize("seed", range(3))
def test_any_within_is_the_bounded_k_d_query_bit_for_bit(seed, monkeypatch):
    """Compiled over a grid and through the tree (a box over the grid's limit) alike: pykdtree's answer, on unit
    directions (the localizer's view), with a query exactly at the radius from a point (no hit), one a hair
    inside it (a hit), and one far outside the points' box."""
    from scipy.spatial import cKDTree

    from bim2rdt.registration import SampleTree

    rng = np.random.default_rng(seed)
    points = rng.normal(0.0, 1.0, (3000, 3))
    points = np.concatenate([points / np.linalg.norm(points, axis=1)[:, None], [[0.5, 0.25, 0.125]]])
    radius = 0.03125  # dyadic: 0.5 + radius - 0.5 is radius exactly
    tie = [0.5 + radius, 0.25, 0.125]
    inside = [np.nextafter(0.5 + radius, 0.0), 0.25, 0.125]
    queries = np.concatenate([rng.normal(0.0, 1.0, (5000, 3)) * 0.7, [tie, inside, [40.0, -3.0, 9.0]]])
    gap, _ = SampleTree(points).query(queries, distance_upper_bound=radius)
    want = np.isfinite(gap)
    assert 0 < want.sum() < len(want) and want[-3:].tolist() == [False, True, False]
    scipy_gap, _ = cKDTree(points).query(queries, distance_upper_bound=radius)
    assert np.array_equal(np.isfinite(scipy_gap), want)  # scipy's bounded query too (new clusters asked it)
    assert np.array_equal(matching.any_within(points, queries, radius), want)
    monkeypatch.setattr(matching, "WITHIN_CUBES", 0)
    assert np.array_equal(matching.any_within(points, queries, radius), want)


@pytest.mark.parametrize("k", [1, 12, 16])
def test_nearest_neighbours_are_scipys(k):
    """On pykdtree where no exact tie can order them otherwise, on scipy where one can (a grid: every point has
    neighbours at equal distances): scipy's lists either way, and the grid does take scipy's path."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(k)
    scattered = rng.normal(0.0, 1.0, (2000, 3)) * [2.0, 1.0, 0.05]
    grid = np.stack(np.meshgrid(*[np.arange(8.0)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    for points in (scattered, grid):
        _, want = cKDTree(points).query(points, k=k)
        assert np.array_equal(matching.nearest_neighbours(points, k), np.asarray(want).reshape(len(points), k))
    if k > 1:  # the grid's ties are real: the fallback was needed (with k = 1 each point's nearest is itself)
        from pykdtree.kdtree import KDTree

        squared, _ = KDTree(grid).query(grid, k=k + 1, sqr_dists=True)
        assert np.any(squared[:, 1:] == squared[:, :-1])


def test_the_warm_started_nearest_samples_are_the_trees(crate_model):
    """A point near its last nearest sample (or its scan neighbour's) is answered from that sample's listed
    neighbours, a point far outside the samples' box is a miss (decision 0045): the same sample and distance
    as the k-d tree, misses beyond the bound included; points it cannot prove go to the tree."""
    model = matching.ModelIndex.build(*crate_model)
    rng = np.random.default_rng(3)
    near = model.points[rng.integers(0, len(model.points), 600)] + rng.normal(0.0, 0.004, (600, 3))
    far = rng.uniform(-1.5, 1.5, (200, 3))
    scene = np.concatenate([near, far])[None].repeat(2, axis=0)
    scene[1] += rng.normal(0.0, 0.01, scene[1].shape)  # a second restart, a centimetre further
    nearest = np.full((3, len(scene[0])), -1, np.int64)
    _, first = model.tree.query(scene[0] + rng.normal(0.0, 0.003, scene[0].shape))  # last iteration's answer
    nearest[0] = nearest[2] = first
    nearest[2, ::7] = -1
    active = np.array([0, 2])
    bound = 0.005  # many a proved point is a miss
    distance, index, cold = kernels.warm_nearest(scene, nearest, active, 1, model.points, model.near_ids,
                                                 model.near_radius, model.low, model.high, bound)
    want_d, want_i = model.tree.query(scene.reshape(-1, 3), distance_upper_bound=bound)
    proved = np.setdiff1d(np.arange(scene.shape[0] * scene.shape[1]), cold)
    assert len(proved) > 0.5 * len(near) * 2
    outside = np.any((scene < model.low - bound) | (scene > model.high + bound), axis=2).reshape(-1)
    assert outside.sum() > 100 and not np.isin(np.flatnonzero(outside), cold).any()  # misses by the box alone
    assert np.array_equal(index.reshape(-1)[proved], want_i[proved])
    assert np.array_equal(distance.reshape(-1)[proved], want_d[proved])
    assert np.isinf(distance.reshape(-1)[proved]).any()  # some proved answers are misses beyond the bound
    found, which = matching.nearest_samples(model, scene, bound, 1, (nearest, active))
    assert np.array_equal(which, want_i.reshape(2, -1)) and np.array_equal(found, want_d.reshape(2, -1))
    assert (nearest[active] == np.where(want_i.reshape(2, -1) < model.tree.n, want_i.reshape(2, -1),
                                        nearest[active])).all()  # remembered where found


def test_a_registration_is_the_same_without_warm_starts(crate_model, cluttered_problem, monkeypatch):
    p = cluttered_problem
    args = (*crate_model, p.scene_pts_world, p.T_world_model_init, UP, 0.6)
    warm = register(*args, support_height=0.0)
    cold = matching.nearest_samples
    monkeypatch.setattr(matching, "nearest_samples", lambda model, scene, bound, stride=1, _=None: cold(
        model, scene, bound, stride, None))
    tree_only = register(*args, support_height=0.0)
    assert np.array_equal(warm.pose, tree_only.pose)
    assert warm.total_iterations == tree_only.total_iterations


def test_the_compiled_patches_are_the_numpy_patches(crate_model):
    """The fit's surface patches (decision 0045): the compiled distances, samples and other-face distances are
    numpy's to round-off, at edges and corners, off the surface and beyond every candidate."""
    model = matching.ModelIndex.build(*crate_model)
    rng = np.random.default_rng(8)
    points = np.concatenate([model.points[rng.integers(0, len(model.points), 500)] + rng.normal(0.0, 0.01, (500, 3)),
                             rng.uniform(model.low - 0.05, model.high + 0.05, (300, 3))])
    distance, index = model.tree.query(points, k=matching.SURFEL_CANDIDATES, distance_upper_bound=0.03)
    got = matching.nearest_patches_of(model, points, distance, index)
    want = matching.nearest_patches_numpy(model, points, distance, index)
    assert np.isinf(want.distance).any() and np.isfinite(want.other_face).sum() > 20  # misses and edges are in it
    assert np.allclose(got.distance, want.distance, rtol=1e-12, atol=1e-15, equal_nan=False)
    assert np.allclose(got.other_face, want.other_face, rtol=1e-12, atol=1e-15)
    assert np.mean(got.sample == want.sample) > 0.99  # a tie within 1 nm may pick its other member
