"""``bim2rdt bench server``: live-stream delivery under load.

A real server (uvicorn on 127.0.0.1, a free port) over a HAV monitor; N SSE clients in a separate process; for
``seconds`` a producer thread emits safety events at ``rate`` per second through the monitor's sink (the exact
path a monitor event takes after its commit: ``HubSink.emit``). Every client must receive every event (lost =
expected - received, per client); latency is the client's receive time minus the emit time (one machine clock).
The same is measured with one client first: the floor the N-client figures are read against.
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from bim2rdt.bus.event import Event

LATENCY_TARGET_MS = 1000.0
"""An event reaches the stream within 1 s of the monitor producing it."""
FLOOR_SECONDS = 10.0
BENCH_KIND = "hav.bench"
"""The kind of the benchmark's events (the clients count these)."""


def run_server_bench(clients: int = 50, seconds: float = 30.0, rate: float = 20.0) -> dict:
    """Results of the floor (1 client) and the load (``clients``) runs, with the targets."""
    from bim2rdt.server import ServerConfig, TokenEntry, create_app, new_token, token_digest
    from bim2rdt.server.hub import HubSink
    from bim2rdt.server.runner import ServerThread

    runs = []
    with tempfile.TemporaryDirectory(prefix="bim2rdt-bench-server-") as folder:
        token = new_token()
        config = ServerConfig(tokens=[TokenEntry(name="bench", role="viewer", sha256=token_digest(token))],
                              stream_backlog=100_000, max_connections=max(256, clients + 64))
        app = create_app(config=config, audit_log=Path(folder) / "audit.jsonl")
        hub = app.state.hub
        hub.queue_size = 100_000
        with ServerThread(app) as server:
            sink = HubSink(hub)
            for n, duration in ((1, min(seconds, FLOOR_SECONDS)), (clients, seconds)):
                runs.append(_run(server, hub, sink, token, n, duration, rate))
    load, floor = runs[-1], runs[0]
    targets = [
        {"name": f"no event lost with {clients} clients", "value": f"{load['lost']} lost of {load['expected']}",
         "passed": load["lost"] == 0 and load["errors"] == 0},
        {"name": f"p99 delivery under {LATENCY_TARGET_MS:g} ms with {clients} clients",
         "value": f"{load['p99_ms']:.1f} ms", "passed": load["p99_ms"] < LATENCY_TARGET_MS},
    ]
    return {"clients": clients, "seconds": seconds, "rate_per_s": rate, "runs": runs,
            "p99_ratio_to_one_client": load["p99_ms"] / max(floor["p99_ms"], 1e-9), "targets": targets,
            "machine": "shared 2-core machine; latencies include the clients' own parsing"}


def _run(server, hub, sink, token: str, clients: int, seconds: float, rate: float) -> dict:
    """One run: start the clients, wait until all are subscribed, emit, end, collect."""
    before = hub.subscribers
    process = subprocess.Popen([sys.executable, "-m", "bim2rdt.bench.sse_clients", server.host, str(server.port),
                                token, str(clients), str(seconds + 60)], stdout=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while hub.subscribers < before + clients and time.monotonic() < deadline:
        time.sleep(0.05)
    emitted = _emit(sink, seconds, rate)
    time.sleep(1.0)
    hub.publish("bench-end", {})
    out, _ = process.communicate(timeout=120)
    result = json.loads(out)
    return _summary(result, clients, emitted)


def _emit(sink, seconds: float, rate: float) -> int:
    """Emit safety events at ``rate`` per second for ``seconds`` from a thread (as the monitor's bus thread
    does); returns how many."""
    count = int(seconds * rate)
    start = time.monotonic()

    def produce() -> None:
        for seq in range(count):
            delay = start + seq / rate - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            now = time.time()
            sink.emit(Event(BENCH_KIND, now, "w-bench", "bench", {"seq": seq, "emitted": now}))

    thread = threading.Thread(target=produce, name="bench-producer")
    thread.start()
    thread.join()
    return count


def _summary(result: dict, clients: int, expected_each: int) -> dict:
    latencies = np.array([lat for got in result["clients"] for _, lat in got] or [np.nan])
    delivered = sum(len({seq for seq, _ in got}) for got in result["clients"])
    expected = clients * expected_each
    return {"clients": clients, "events": expected_each, "expected": expected, "delivered": delivered,
            "lost": expected - delivered, "errors": len(result["errors"]),
            "p50_ms": round(float(np.nanpercentile(latencies, 50)), 2),
            "p99_ms": round(float(np.nanpercentile(latencies, 99)), 2),
            "max_ms": round(float(np.nanmax(latencies)), 2),
            "mean_ms": round(float(statistics.fmean(latencies[np.isfinite(latencies)])) if delivered else 0.0, 2)}
