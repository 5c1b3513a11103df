"""`bench hav --scale` end to end on a small fleet: the backlog drained by 1 and by 2 monitor processes in turn, and
the latency run, every message committed once and accounted for."""

from __future__ import annotations

import numpy as np

from bim2rdt.bench.hav_scale import _drain_runs, _latency_run, _raw_payloads, targets


def test_the_drains_take_turns_and_report_their_median_round():
    messages = _raw_payloads(4, 6, 5000.0)
    publisher, runs = _drain_runs(messages, 5000.0, rounds=3)
    assert publisher["messages"] == 24 and publisher["msgs_per_s"] > 0
    for processes in (1, 2):
        run = runs[processes]
        assert len(run["per_process"]) == processes and sum(run["per_process"]) == 24  # each drain took them all
        assert len(run["rounds_msgs_per_s"]) == 3
        assert run["msgs_per_s"] == float(np.median(run["rounds_msgs_per_s"]))


def test_the_latency_run_times_every_message_from_publish_to_commit():
    latency = _latency_run(4, 5000.0, rate=40.0, seconds=3.0)
    assert latency["messages"] == latency["committed"] >= 30  # the last second (after the warm-up), all committed
    assert 0 < latency["p50_ms"] <= latency["p99_ms"] <= latency["max_ms"] < 5000
    assert set(latency["stages_ms"]) == {"publish_to_stored", "stored_to_fetched", "fetched_to_committed"}
    verdict = targets({"throughput": {"scaling": 1.69}, "latency": latency})
    assert verdict["two_processes_ge_1_7x_one"] is False
