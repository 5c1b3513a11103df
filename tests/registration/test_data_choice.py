"""The choice between the prior's result and plain ICP's (issue 26): the data decide, the prior cannot swap the
data's basin for one it likes."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.registration import IcpConfig, register
from bim2rdt.registration import icp
from bim2rdt.registration.icp import RegistrationResult, data_choice, keep_data_choice, prior_beats_data
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


def test_the_rule_ignores_a_penalty_that_would_outweigh_the_datas_lead():
    """Constructed: the prior-free pose leads on the data by ~4 standard errors, but it is tilted, and its
    upright penalty is larger than that lead, so the prior-weighted score (the loop's objective) prefers the
    prior's pose. The rule reads the data alone: the prior's pose does not beat it, the data's choice stands."""
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


def test_within_the_noise_the_prior_breaks_the_tie():
    """Data terms ~0.4 standard errors apart: a tie. The pose whose data term plus upright penalty is lower is
    kept: plain ICP's when both stand upright and its data term is the lower, the prior's when plain ICP's is
    tilted (its penalty) although its data term is a hair lower."""
    rng = np.random.default_rng(2)
    prior = rng.uniform(0.0, 1e-4, 400)
    free = prior + rng.normal(-2e-6, 1e-4, 400)
    per_point = np.stack([prior, free])
    assert not prior_beats_data(per_point, 2.0) and not prior_beats_data(per_point[::-1], 2.0)
    gap = per_point[0].mean() - per_point[1].mean()
    assert gap > 0.0  # plain ICP's data term is the lower one
    assert data_choice(per_point, np.zeros(2), 2.0) == 1
    assert data_choice(per_point, np.array([0.0, 2.0 * gap]), 2.0) == 0


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
    """The tilt trap: plain ICP ended 15 degrees tilted and the prior's upright pose is the truth; the data
    prefer the truth by far, so the prior's result stands unchanged."""
    pose, place = make_pose, placed
    truth = pose(0.3, 0.0, (0.2, 0.1, 0.0))
    tilted = pose(0.3, np.deg2rad(15.0), (0.2, 0.1, 0.05))
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
