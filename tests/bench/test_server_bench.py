"""`bench server`, short: SSE clients in their own process on a real server lose no event the monitor's sink
emits, and deliver within the 1 s target (the 30 s, 50-client run is `bim2rdt bench server`)."""

from __future__ import annotations


def test_a_short_load_run_loses_nothing_and_meets_the_latency_target():
    from bim2rdt.bench.server import run_server_bench

    result = run_server_bench(clients=10, seconds=2.0, rate=25.0)
    floor, load = result["runs"]
    assert (floor["clients"], load["clients"]) == (1, 10)
    assert load["expected"] == 10 * 50 and load["delivered"] == load["expected"] and load["lost"] == 0
    assert load["errors"] == 0
    assert 0 < load["p50_ms"] <= load["p99_ms"] < 1000.0
    assert all(target["passed"] for target in result["targets"])
