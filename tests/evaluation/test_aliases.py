"""Issue 26's alias families: the scenes are what the issue describes, and SG-ICP no longer leaves a cone in
the slid alias plain ICP avoids."""

from __future__ import annotations

import numpy as np

from bim2rdt.evaluation.aliases import ALIAS_FAMILIES, alias_scenario
from bim2rdt.registration import IcpConfig, register
from bim2rdt.sim.truth import pose_error


def test_both_generators_build_sparse_cluttered_views_from_tilted_starts():
    for name in ALIAS_FAMILIES:
        built = alias_scenario(name, trials=2, seed=0)
        for obj in (o for trial in built.trials for o in trial):
            assert 100 <= len(obj.scene_pts_world) <= 1.1 * 200 + 1  # 100-200 points plus 10 % clutter
            tilt = np.rad2deg(np.arccos(np.clip(obj.T_init[2, 2], -1.0, 1.0)))
            assert 19.9 <= tilt <= 35.1
            assert obj.support_height is None


def test_the_cone_plain_icp_finds_is_not_lost_to_the_priors_slide():
    """F10 trial 19 (seed 0; trial 3 before the per-object generators of issue 24): every restart under the
    prior ends 3 cm up the cone's axis (a local minimum the levelled starts all fall into), while plain ICP's
    tilted restarts reach the truth. With plain ICP's search beside the prior's and the data choosing, SG-ICP
    ends at the truth (0.5 mm); without it (the former behaviour) it stays slid (29 mm)."""
    built = alias_scenario("F10", trials=20, seed=0)
    cone = built.trials[19][0]
    config = IcpConfig(sample_count=ALIAS_FAMILIES["F10"].sample_count)

    def error(cfg):
        found = register(*built.models[cone.family], cone.scene_pts_world, cone.T_init, upright_bias=0.9, config=cfg)
        return pose_error(cone.family, found.pose, cone.T_world_model, cone.symmetry_order)

    assert error(config.model_copy(update={"prior_free_pass": False})).translation > 0.02
    assert error(config).translation < 0.005


def test_one_draw_more_in_one_view_changes_no_other_object_or_trial(monkeypatch):
    """Issue 24: a view's draw count follows its ray hits (last bits differ between machines); each object of
    each trial has its own generator, so trial 0's first view drawing once more changes nothing else."""
    import bim2rdt.evaluation.aliases as aliases

    name = next(iter(ALIAS_FAMILIES))
    before = alias_scenario(name, trials=3, seed=2)
    calls = []
    for view_name in ("rendered_view", "sampled_view"):
        def one_more_draw(mesh, T_true, count, spec, rng, _view=getattr(aliases, view_name)):
            calls.append(count)
            if len(calls) == 1:
                rng.random()
            return _view(mesh, T_true, count, spec, rng)
        monkeypatch.setattr(aliases, view_name, one_more_draw)
    after = alias_scenario(name, trials=3, seed=2)
    pairs = [(t, i, obj, after.trials[t][i]) for t, trial in enumerate(before.trials) for i, obj in enumerate(trial)]
    assert {(t, i) for t, i, a, b in pairs if not np.array_equal(a.scene_pts_world, b.scene_pts_world)} == {(0, 0)}
    assert all(np.array_equal(a.T_init, b.T_init) for *_, a, b in pairs)  # the start is drawn before the view
