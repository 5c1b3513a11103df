"""The choice between the prior's result and plain ICP's (issue 26): the data decide, the prior cannot swap the
data's basin for one it likes."""

from __future__ import annotations

import numpy as np

from bim2rdt.registration import IcpConfig, register
from bim2rdt.registration import icp
from bim2rdt.registration.icp import (RegistrationResult, data_choice, keep_data_choice, prior_beats_data,
                                      prior_kept)
from bim2rdt.registration.matching import ModelIndex
from bim2rdt.registration.validation import validate_problem


def _result(pose: np.ndarray) -> RegistrationResult:
    return RegistrationResult(pose=pose, rmse=float("nan"), fitness=float("nan"), iterations=1, score=0.0,
                              restart=0, converged=True, tilt_deg=0.0, total_iterations=1)


def _centroid(pose: np.ndarray, model_pts: np.ndarray) -> np.ndarray:
    return pose[:3, :3] @ model_pts.mean(axis=0) + pose[:3, 3]


def test_the_prior_wins_only_beyond_the_paired_noise():
    rng = np.random.default_rng(0)
    data = rng.uniform(0.0, 1e-4, 400)
    clearly_lower = np.stack([data, data + 2e-5])  # the prior's pose (row 0) 20 um^2 lower at every point
    noisy = np.stack([data, data + rng.normal(0.0, 1e-4, 400) + 2e-6])  # 2 um^2 lower on average, noise 100
    assert prior_beats_data(clearly_lower, 2.0)
    assert not prior_beats_data(clearly_lower[::-1], 2.0)  # the prior's pose is the worse one
    assert not prior_beats_data(noisy, 2.0)  # ~0.4 standard errors: a tie, the data's choice stands


def test_a_penalty_cannot_outweigh_the_datas_clear_lead():
    """Constructed: the prior-free pose leads on the data by ~6 standard errors, but it is tilted, and its
    upright penalty is larger than that lead, so the prior-weighted score (the loop's objective) prefers the
    prior's pose. Where the data clearly prefer a pose, the prior cannot overrule them: the data's choice
    stands."""
    rng = np.random.default_rng(1)
    free = rng.uniform(0.0, 1e-4, 300)
    prior = free + rng.normal(4e-6, 1e-5, 300)  # worse at most points: ~6 standard errors behind
    per_point = np.stack([prior, free])
    lead = per_point[0].mean() - per_point[1].mean()
    penalties = np.array([0.0, 2.0 * lead])  # the tilted pose pays twice its lead
    assert np.argmin(per_point.mean(axis=1) + penalties) == 0  # the prior-weighted score picks the prior's
    assert not prior_beats_data(per_point, 2.0)
    assert prior_beats_data(per_point[::-1], 2.0)  # with the roles swapped, the data do pick it
    assert data_choice(per_point, penalties, 2.0) == 1  # the data's choice: plain ICP's pose


def test_a_tie_between_upright_aliases_keeps_plain_icps_basin():
    """Data terms ~0.4 standard errors apart, the prior's pose the lower, both upright (no penalty): a tie the
    prior knows nothing about, so plain ICP's basin stands, whichever data term is a hair lower."""
    rng = np.random.default_rng(2)
    free = rng.uniform(0.0, 1e-4, 400)
    prior = free + rng.normal(-2e-6, 1e-4, 400)
    per_point = np.stack([prior, free])
    assert not prior_beats_data(per_point, 2.0) and not prior_beats_data(per_point[::-1], 2.0)
    assert per_point[0].mean() < per_point[1].mean()  # the prior's data term is the lower one
    assert data_choice(per_point, np.zeros(2), 2.0) == 1
    assert data_choice(per_point[::-1], np.zeros(2), 2.0) == 1  # either way round: ICP's, not the lower


def test_within_the_noise_the_prior_wins_where_it_knows_the_tilt():
    """The same tie, but plain ICP's pose is tilted: its upright penalty exceeds 2 standard errors of the data's
    paired difference, so the objective the prior shapes prefers the prior's pose beyond the noise, and it is
    kept; a penalty within the noise does not decide."""
    rng = np.random.default_rng(2)
    prior = rng.uniform(0.0, 1e-4, 400)
    free = prior + rng.normal(0.0, 1e-4, 400)
    per_point = np.stack([prior, free])
    difference = per_point[1] - per_point[0]
    noise = difference.std() / np.sqrt(400)
    assert abs(difference.mean()) < 2.0 * noise  # a tie on the data
    penalty = 3.0 * noise + max(0.0, -difference.mean())
    assert data_choice(per_point, np.array([0.0, penalty]), 2.0) == 0
    assert data_choice(per_point, np.array([0.0, 1.0 * noise]), 2.0) == 1


def test_a_leaning_objects_basin_is_kept_when_the_data_prefer_icps_pose_as_found():
    """A truly leaning object: the prior's polish takes part of ICP's lean, and against that polished pose
    the prior's (a wrong basin, less tilted) wins on the objective; but ICP's pose as found fits the data
    beyond the noise better than the prior's, so ICP's basin is kept (the release test gives the lean back)."""
    rng = np.random.default_rng(4)
    prior = rng.uniform(0.0, 1e-4, 300)
    polished = prior + rng.normal(1e-6, 2e-5, 300)  # a tie on the data ...
    found = prior - 2e-5 + rng.normal(0.0, 2e-5, 300)  # ... ICP as found is lower by ~17 standard errors
    per_point = np.stack([prior, polished, found])
    penalties = np.array([0.0, 2e-5, 4e-5])  # the polished pose is still tilted: the prior wins its objective
    assert data_choice(per_point[:2], penalties[:2], 2.0) == 0
    assert not prior_kept(per_point, penalties, 2.0)
    assert prior_kept(np.stack([prior, polished, polished]), penalties, 2.0)


def test_the_surface_terms_read_the_distance_to_the_surface_not_a_samples_plane(crate_model, make_pose, placed):
    """Noise-free points on the crate at its true pose, against a model of 2,000 samples (F11's density): they
    lie on the surface (RMS under 3 mm: a few points at the cleats' edges), while the nearest sample's plane
    puts points in the gaps between samples and at edges a centimetre off (RMS 11 mm)."""
    from bim2rdt.registration import sample_model
    from bim2rdt.sim.meshes import wooden_crate

    points, _ = sample_model(wooden_crate(), 4000, seed=7)
    visible = points[(points[:, 0] > -0.3) & (points[:, 1] < 0.2)][:300]
    truth = make_pose(0.3, 0.0, (0.2, 0.1, 0.0))
    model = ModelIndex.cached(*crate_model)
    cfg = IcpConfig()
    terms = icp.surface_terms(model, truth[None], placed(truth, visible), cfg)
    _, pairs = icp.score_poses(model, truth[None], placed(truth, visible), cfg)
    plane = np.minimum(pairs.residual, cfg.score_distance) ** 2
    assert np.sqrt(terms.mean()) < 0.003
    assert np.sqrt(plane.mean()) > 3 * np.sqrt(terms.mean())


def test_plain_icps_basin_is_judged_after_the_prior_levels_it(crate_model, crate_view, make_pose, placed):
    """Plain ICP's result is the true basin but 3 degrees tilted (a tilt fitted to noise); the prior's result
    stands upright 1 cm beside the truth. Judged raw, ICP's tilt outweighs the slide and the prior's alias
    would win; ICP's pose is judged after the polish with the prior that would keep it, and then the data
    prefer it beyond the noise: the truth is kept, levelled."""
    truth = make_pose(0.3, 0.0, (0.2, 0.1, 0.0))
    slid = truth.copy()
    slid[:3, 3] += slid[:3, :3] @ np.array([0.0, 0.01, 0.0])
    scene = placed(truth, crate_view)
    problem = validate_problem(*crate_model, scene, truth, (0.0, 0.0, 1.0), 0.9, None)
    model = ModelIndex.cached(problem.model_pts_body, problem.model_normals_body)
    tilted = make_pose(0.3, np.deg2rad(3.0))
    tilted[:3, 3] = _centroid(truth, crate_model[0]) - tilted[:3, :3] @ crate_model[0].mean(axis=0)
    kept = keep_data_choice(_result(slid), _result(tilted), problem, model, None, IcpConfig())
    assert np.linalg.norm(_centroid(kept.pose, crate_model[0]) - _centroid(truth, crate_model[0])) < 0.005
    assert kept.tilt_deg < 1.0


def test_the_datas_basin_is_kept_over_the_priors_slid_alias(crate_model, crate_view, make_pose, placed):
    """The prior's result stands upright 2 cm beside the truth (the slide a sparse view allows); plain ICP's
    result is the truth. The data prefer the truth beyond the noise, so it is kept (levelled by the prior's
    polish, which moves it by millimetres, not into the slid alias)."""
    truth = make_pose(0.3, 0.0, (0.2, 0.1, 0.0))
    slid = truth.copy()
    slid[:3, 3] += slid[:3, :3] @ np.array([0.0, 0.02, 0.0])
    scene = placed(truth, crate_view)
    problem = validate_problem(*crate_model, scene, truth, (0.0, 0.0, 1.0), 0.9, None)
    model = ModelIndex.cached(problem.model_pts_body, problem.model_normals_body)
    kept = keep_data_choice(_result(slid), _result(truth), problem, model, None, IcpConfig())
    assert np.linalg.norm(_centroid(kept.pose, crate_model[0]) - _centroid(truth, crate_model[0])) < 0.005
    assert kept.total_iterations > 2  # the polish with the prior ran


def test_the_prior_keeps_its_result_when_the_data_prefer_it(crate_model, crate_view, make_pose, placed):
    """The tilt trap: plain ICP ended with the crate on its side (90 degrees tilted, beyond what the polish with
    the prior levels) and the prior's upright pose is the truth; the data and the penalty prefer the truth by
    far, so the prior's result stands unchanged."""
    pose, place = make_pose, placed
    truth = pose(0.3, 0.0, (0.2, 0.1, 0.0))
    tilted = pose(0.3, np.deg2rad(90.0), (0.2, 0.1, 0.3))
    scene = place(truth, crate_view)
    problem = validate_problem(*crate_model, scene, tilted, (0.0, 0.0, 1.0), 0.9, None)
    model = ModelIndex.cached(problem.model_pts_body, problem.model_normals_body)
    kept = keep_data_choice(_result(truth), _result(tilted), problem, model, None, IcpConfig())
    assert np.array_equal(kept.pose, truth)


def test_register_runs_plain_icp_beside_the_prior_and_can_be_told_not_to(crate_model, crate_view, make_pose,
                                                                          placed, monkeypatch):
    """Under a prior, register runs plain ICP's search too (bias 0, the unlevelled start); without a prior, or
    with prior_free_pass off, it does not."""
    truth = make_pose(0.3, 0.0, (0.2, 0.1, 0.0))
    scene = placed(truth, crate_view)
    biases = []
    real = icp._keep_best
    monkeypatch.setattr(icp, "_keep_best",
                        lambda restarts, problem, *args: biases.append(problem.upright_bias) or real(restarts, problem,
                                                                                                     *args))
    register(*crate_model, scene, truth, upright_bias=0.9)
    assert biases == [0.9, 0.0]
    biases.clear()
    register(*crate_model, scene, truth, upright_bias=0.0)
    register(*crate_model, scene, truth, upright_bias=0.9, config=IcpConfig(prior_free_pass=False))
    assert biases == [0.0, 0.9]


def test_on_a_tie_a_pose_beyond_the_loops_reach_of_the_guess_loses():
    """A tie on the data (~0.4 standard errors): the prior's pose is kept when ICP's polished pose carried the
    object beyond the loop's reach of the guess and the prior's did not; not when both are within reach, nor
    when the prior's is the far one, nor when ICP's leads beyond the noise (on the objective, or as found)."""
    rng = np.random.default_rng(2)
    prior = rng.uniform(0.0, 1e-4, 400)
    polished = prior + rng.normal(-2e-6, 1e-4, 400)  # a hair lower: a tie
    per_point = np.stack([prior, polished, polished])
    zero = np.zeros(3)
    assert not prior_kept(per_point, zero, 2.0)  # the data alone keep ICP's basin
    assert icp.guess_decides(per_point, zero, np.array([False, True]), 2.0)
    assert not icp.guess_decides(per_point, zero, np.array([False, False]), 2.0)
    assert not icp.guess_decides(per_point, zero, np.array([True, True]), 2.0)
    assert not icp.guess_decides(per_point, zero, np.array([True, False]), 2.0)
    leading = np.stack([prior, prior - 2e-5, prior - 2e-5])  # ICP's lower at every point
    assert not icp.guess_decides(leading, zero, np.array([False, True]), 2.0)
    assert not icp.guess_decides(np.stack([prior, polished, prior - 2e-5]), zero, np.array([False, True]), 2.0)
    assert not icp.guess_decides(per_point, np.array([0.0, -1e-4, 0.0]), np.array([False, True]), 2.0)


def test_beyond_reach_measures_the_models_centroid_from_where_the_guess_put_it(crate_model, make_pose):
    guess = make_pose(0.3, 0.0, (0.2, 0.1, 0.0))
    problem = validate_problem(*crate_model, np.zeros((10, 3)) + np.arange(10)[:, None] * 0.01, guess,
                               (0.0, 0.0, 1.0), 0.9, None)
    centroid = crate_model[0].mean(axis=0)
    turned = make_pose(np.pi + 0.3, 0.0)  # the centroid turned about the vertical through the body origin
    turned[:3, 3] = _centroid(guess, crate_model[0]) - turned[:3, :3] @ centroid  # ... and put back
    far = guess.copy()
    far[:3, 3] += (0.2, 0.2, 0.0)  # 28 cm away
    assert icp.beyond_reach(np.stack([guess, turned, far]), problem, centroid, 0.25).tolist() == [False, False,
                                                                                                  True]


def test_a_lid_patch_slid_beyond_reach_of_the_guess_keeps_the_priors_pose(crate_model, make_pose, placed):
    """A patch of the crate's lid fits anywhere on the lid: ICP's result slid 30 cm along it ties with the
    prior's at the guess, and the guess decides (the prior's pose is kept). Guessed at the slid pose instead,
    the prior's is the far one and ICP's (polished: on a flat patch the polish slides it a few cm) is kept."""
    from bim2rdt.registration import sample_model
    from bim2rdt.sim.meshes import wooden_crate

    points, normals = sample_model(wooden_crate(), 20000, seed=7)
    patch = points[(normals[:, 2] > 0.9) & (np.abs(points[:, 0]) < 0.12) & (np.abs(points[:, 1]) < 0.12)]
    patch = patch + np.random.default_rng(5).normal(0.0, 0.001, patch.shape)
    truth = make_pose(0.3, 0.0, (0.2, 0.1, 0.0))
    slid = truth.copy()
    slid[:3, 3] += slid[:3, :3] @ np.array([0.3, 0.0, 0.0])
    scene = placed(truth, patch)
    model = ModelIndex.cached(*crate_model)
    for guess, expected, other in ((truth, truth, slid), (slid, slid, truth)):
        problem = validate_problem(*crate_model, scene, guess, (0.0, 0.0, 1.0), 0.9, None)
        kept = keep_data_choice(_result(truth), _result(slid), problem, model, None, IcpConfig())
        assert np.linalg.norm(_centroid(kept.pose, crate_model[0]) - _centroid(expected, crate_model[0])) < 0.1
        assert np.linalg.norm(_centroid(kept.pose, crate_model[0]) - _centroid(other, crate_model[0])) > 0.2
