"""The four seeded scenarios: reproducible, perturbed within their bounds, and SG-ICP beats ICP on them."""

from __future__ import annotations

import numpy as np

from bim2rdt.registration import IcpConfig
from bim2rdt.sim.benchmark import run_scenario
from bim2rdt.sim.peers import SgIcp
from bim2rdt.sim.registration_runs import upright_priors
from bim2rdt.sim.scenarios import SCENARIOS, scenario
from bim2rdt.sim.truth import pose_error


def test_the_same_seed_gives_the_same_trials():
    a, b = scenario("S2", trials=2, seed=5), scenario("S2", trials=2, seed=5)
    for trial_a, trial_b in zip(a.trials, b.trials):
        for obj_a, obj_b in zip(trial_a, trial_b):
            assert np.array_equal(obj_a.scene_pts_world, obj_b.scene_pts_world)
            assert np.array_equal(obj_a.T_init, obj_b.T_init)


def test_s1_to_s3_share_one_layout_seen_from_different_viewpoints():
    layouts = {SCENARIOS[name].layout for name in ("S1", "S2", "S3")}
    eyes = {SCENARIOS[name].eye for name in ("S1", "S2", "S3")}
    assert len(layouts) == 1 and len(eyes) == 3


def test_initial_poses_are_perturbed_within_the_scenario_bounds():
    built = scenario("S1", trials=4, seed=1)
    spec = built.spec
    for trial in built.trials:
        for obj in trial:
            error = pose_error("none", obj.T_init, obj.T_world_model)
            assert 0.0 < error.tilt_deg <= spec.max_tilt_deg + 1e-6
            assert error.rotation_deg <= spec.max_tilt_deg + spec.max_yaw_deg + 1e-6
            assert len(obj.scene_pts_world) >= 6


def test_sg_icp_beats_icp_on_tilted_partial_views_of_poorly_featured_families():
    built = scenario("S4", trials=3, seed=0)
    priors = upright_priors([family for family, *_ in built.spec.layout])
    config = IcpConfig()
    result = run_scenario(built, [SgIcp(config, use_prior=False), SgIcp(config, use_prior=True)], priors)
    icp, sg = result.stats["ICP"], result.stats["SG-ICP"]
    assert sg.tilt_deg < icp.tilt_deg
    assert sg.rmse < icp.rmse
