"""The benchmark's verdicts: the paired bootstrap interval of a cut, and how the targets read it."""

from __future__ import annotations

import numpy as np

from bim2rdt.evaluation.stats import ScenarioResult, _summarise, check_targets, cut_interval, improvement


def _result(name: str, icp_rmse, sg_rmse) -> ScenarioResult:
    """A scenario whose rows carry the given per-registration RMSEs (Max = 3 x RMSE, all successes)."""
    result = ScenarioResult(name, "synthetic")
    for method, values in (("ICP", icp_rmse), ("SG-ICP", sg_rmse)):
        result.rows[method] = [(v, v, 3 * v, True, 0.0, 0.01, "ok", False) for v in values]
        result.stats[method] = _summarise(result.rows[method])
    return result


def test_the_interval_brackets_the_cut_and_narrows_with_more_pairs():
    rng = np.random.default_rng(1)
    icp = rng.uniform(0.002, 0.02, 400)
    sg = icp * rng.uniform(0.3, 0.7, 400)  # a real ~50 % cut
    few, many = _result("A", icp[:40], sg[:40]), _result("B", icp, sg)
    for result in (few, many):
        low, high = cut_interval(result)
        cut = improvement(result.stats["ICP"].rmse, result.stats["SG-ICP"].rmse)
        assert low < cut < high and 35.0 < low and high < 65.0
    assert np.ptp(cut_interval(many)) < np.ptp(cut_interval(few))


def test_identical_methods_give_a_zero_width_interval_at_zero():
    values = np.linspace(0.001, 0.01, 50)
    assert cut_interval(_result("A", values, values)) == (0.0, 0.0)


def test_a_cut_below_zero_within_the_noise_is_reported_but_does_not_fail_the_no_worse_target():
    rng = np.random.default_rng(2)
    icp = rng.uniform(0.002, 0.004, 150)
    scatter = np.where(np.arange(150) % 2 == 0, 0.0004, -0.0004)
    noisy = icp + rng.permutation(scatter) + 0.00002  # 0.02 mm worse on average, +-0.4 mm per registration
    clearly = icp * 1.3  # 30 % worse on every registration
    no_worse = check_targets([_result("S1", icp, noisy)])[1]
    assert no_worse.passed and "within noise" in no_worse.detail and "S1" in no_worse.detail
    assert not check_targets([_result("S1", icp, clearly)])[1].passed


def test_the_cut_target_looks_at_the_two_scenarios_hardest_for_icp():
    base = np.full(30, 0.01)
    results = [_result("S1", base, base * 0.3), _result("S2", base * 0.2, base * 0.2),
               _result("S3", base * 2, base * 0.5), _result("S4", base * 0.5, base * 0.5)]
    cut = check_targets(results)[0]
    assert cut.passed and cut.detail.startswith("S3 75.0 %") and "S1 70.0 %" in cut.detail
    results[0] = _result("S1", base, base * 0.5)
    assert not check_targets(results)[0].passed


def test_s4_success_is_judged_against_85_percent_when_s4_ran():
    base = np.full(20, 0.01)
    s4 = _result("S4", base, base)
    target = [t for t in check_targets([s4]) if t.name.startswith("S4 SG-ICP success")]
    assert len(target) == 1 and target[0].passed  # every row is a success
    s4.rows["SG-ICP"] = [row[:3] + (i < 16,) + row[4:] for i, row in enumerate(s4.rows["SG-ICP"])]
    s4.stats["SG-ICP"] = _summarise(s4.rows["SG-ICP"])  # 80 %
    assert not [t for t in check_targets([s4]) if t.name.startswith("S4 SG-ICP success")][0].passed
    assert not [t for t in check_targets([_result("S1", base, base)]) if t.name.startswith("S4")]
