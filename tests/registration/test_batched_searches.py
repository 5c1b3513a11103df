"""The prior's and plain ICP's searches run as one batch (issue 26's prior-free pass, made cheap): every restart
and every hop must end exactly where its own search, run alone, ends."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from bim2rdt.registration import IcpConfig
from bim2rdt.registration import icp
from bim2rdt.registration.matching import ModelIndex
from bim2rdt.registration.validation import validate_problem


@pytest.fixture
def problems(crate_model, crate_view, make_pose, placed):
    """A cluttered crate view, started 20 degrees tilted and 25 off in yaw, under a prior and without one."""
    truth = make_pose(0.3, 0.0, (0.2, 0.1, 0.0))
    clutter = np.random.default_rng(5).uniform([-0.5, -0.5, 0.0], [0.9, 0.7, 0.6], (60, 3))
    scene = np.concatenate([placed(truth, crate_view), clutter])
    start = make_pose(0.3 + np.deg2rad(25.0), np.deg2rad(20.0), (0.25, 0.05, 0.03))
    prior = validate_problem(*crate_model, scene, start, (0.0, 0.0, 1.0), 0.9, None)
    return prior, replace(prior, upright_bias=0.0)


def _same(a: icp._Restarts, b: icp._Restarts) -> None:
    assert np.array_equal(a.poses, b.poses)
    assert np.array_equal(a.iterations, b.iterations)
    assert np.array_equal(a.done, b.done) and np.array_equal(a.pruned, b.pruned)


def test_restarts_searched_together_end_exactly_where_each_search_alone_ends(problems):
    cfg = IcpConfig(prune_keep=5)
    model = ModelIndex.cached(problems[0].model_pts_body, problems[0].model_normals_body)
    together = icp._search_together(list(problems), model, None, cfg)
    for problem, batched in zip(problems, together):
        alone = icp._search(icp._restart_starts(problem, model, cfg, False), problem, model, None, cfg, False)
        assert alone.pruned.any()  # pruning ran, and must have run among each search's own restarts
        _same(batched, alone)


def test_hops_run_together_keep_exactly_what_each_search_alone_keeps(problems, monkeypatch):
    """Every hop round's searched restarts (recorded per bias), and the kept results, are those of each search
    hopping alone."""
    cfg = IcpConfig(hop_rounds=2)
    model = ModelIndex.cached(problems[0].model_pts_body, problems[0].model_normals_body)
    kept = [icp._keep_best(restarts, problem, model, cfg)
            for problem, restarts in zip(problems, icp._search_together(list(problems), model, None, cfg))]
    rounds: dict[str, list] = {"together": [], "alone": []}
    real = icp._next_round

    def recorded(generator, searched):
        if searched is not None:
            rounds[mode].append((generator.gi_frame.f_locals["problem"].upright_bias, searched.poses.copy()))
        return real(generator, searched)

    monkeypatch.setattr(icp, "_next_round", recorded)
    mode = "together"
    together = icp._hop_together(kept, list(problems), model, None, cfg)
    mode = "alone"
    alone = [icp.hop(best, problem, model, None, cfg, False) for problem, best in zip(problems, kept)]
    for bias in (0.9, 0.0):
        searched_together = [poses for b, poses in rounds["together"] if b == bias]
        searched_alone = [poses for b, poses in rounds["alone"] if b == bias]
        assert len(searched_together) == len(searched_alone) >= 1
        assert all(np.array_equal(a, b) for a, b in zip(searched_together, searched_alone))
    for best, batched, single in zip(kept, together, alone):
        assert np.array_equal(batched.pose, single.pose)
        assert batched.total_iterations == single.total_iterations > best.total_iterations


def test_hops_searches_keep_at_most_hop_prune_keep_restarts(problems):
    """Hops start a few degrees and centimetres apart, so the score ratio keeps nearly all of them at
    prune_after; hop_prune_keep caps the survivors of a hop search (and only of a hop search)."""
    cfg = IcpConfig(hop_prune_keep=3, stop_when_agreed=0)  # the cap alone (the stop drops losers later too)
    model = ModelIndex.cached(problems[0].model_pts_body, problems[0].model_normals_body)
    starts = icp.hop_starts(problems[0].T_world_model_init, model.centroid, problems[0].up_world, cfg, level=True)
    hopped = icp._search(starts, problems[0], model, None, cfg, False, hopping=True)
    searched = icp._search(starts, problems[0], model, None, cfg, False)
    assert (~hopped.pruned).sum() == 3
    assert (~searched.pruned).sum() > 3
    together = icp._search_together(list(problems), model, None, cfg, [starts, starts], hopping=True)
    assert all((~part.pruned).sum() == 3 for part in together)
