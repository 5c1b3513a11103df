"""`bench hav --scale`: the NATS path's monitor processes, measured against themselves in one run.

Throughput: a backlog of raw batches (0.5 s, 3 axes int16 at ``fs``; every wearable's) is published over MQTT
3.1.1 to a private nats-server before any monitor runs; then 1, and (its consumers deleted) 2 monitor processes
consume it: durable pull consumers, each fetch one group commit into the process's own SQLite store, acknowledged
after it. msgs/s = backlog / (last process done - start signal). Summaries: the same with a backlog of 1 Hz
on-device summaries and one process.

Latency: with 2 monitor processes running, the wearables publish in real time at ``LATENCY_LOAD`` of the measured
1-process throughput, evenly spread; per batch, publish call (device side) to its commit in a monitor (the moment
its exposure and events exist), p50/p99 over all batches after the first ``WARMUP_S`` seconds.

The wearables are :class:`~bim2rdt.bench.mqtt_fleet.MqttFleet`: one thread writing QoS 1 PUBLISH packets on a
connection per device. On a site each wearable is a device of its own; here the publisher shares the cores with
nats-server and the monitors, so it must cost them as little as it can (decision 0028). Each monitor process
settles its heap before its first message, as ``hav listen`` does (:mod:`~bim2rdt.safety.heap`).
"""

from __future__ import annotations

import gc
import multiprocessing
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from bim2rdt.bench.mqtt_fleet import MqttFleet
from bim2rdt.bus.nats_broker import NatsServer
from bim2rdt.bus.partitions import partition_of
from bim2rdt.bus.payloads import AccelBatch, encode_accel
from bim2rdt.bus.summaries import encode_summary, summary_topic
from bim2rdt.bus.topics import accel_topic
from bim2rdt.safety.heap import settle
from bim2rdt.safety.summary import SummaryDevice
from bim2rdt.sim.vibration import WEARABLE_RANGE, ToolSignal

SITE, SECRET, MONITOR = "bench", "bench-secret", "monitor"
TARGET_SCALING = 1.7
WARMUP_S = 2.0
"""Seconds of the latency run left out of its figures: the monitors' first fetches and commits (imports, caches)."""
TARGET_P99_MS = 100.0
ROUNDS = 3
"""Drains of the backlog by 1 and by 2 processes, taken in turn: the figures are each one's median round (a shared
2-core machine varies by 10-20 % from one drain to the next)."""
LATENCY_LOAD = 0.5
"""The latency run's offered load, as a fraction of the measured 1-process throughput."""


def targets(result: dict) -> dict[str, bool]:
    return {"two_processes_ge_1_7x_one": result["throughput"]["scaling"] >= TARGET_SCALING,
            "latency_p99_le_100ms": result["latency"]["p99_ms"] <= TARGET_P99_MS}


def run_scale(devices: int = 100, batches: int = 120, fs: float = 5000.0, summaries: int = 200,
              latency_s: float = 10.0, rounds: int = ROUNDS, tick=None) -> dict:
    """Publisher, then throughput with 1 and 2 processes on one backlog, summaries with 1, latency with 2 at
    ``LATENCY_LOAD`` of the 1-process throughput (see the module docstring)."""
    tick = tick or (lambda: None)
    raw = _raw_payloads(devices, batches, fs)
    publisher, runs = _drain_runs(raw, fs, rounds)
    tick()
    summary_run = _backlog_run(_summary_payloads(devices, summaries, fs), 1, fs)
    tick()
    one, two = runs[1]["msgs_per_s"], runs[2]["msgs_per_s"]
    latency = _latency_run(devices, fs, LATENCY_LOAD * one, latency_s)
    tick()
    bytes_per_batch = float(np.mean([len(p) for _, _, p in raw]))
    per_cpu = [runs[k]["msgs_per_cpu_s_per_process"] for k in (1, 2)]
    return {"publisher": publisher,
            "throughput": {"devices": devices, "messages": len(raw), "fs": fs, "bytes_per_message": bytes_per_batch,
                           "one_process_msgs_per_s": one, "two_processes_msgs_per_s": two, "scaling": two / one,
                           "cpu_scaling": 2 * per_cpu[1] / per_cpu[0], "per_process": runs},
            "summaries": {"messages": summary_run["messages"], "msgs_per_s_per_process": summary_run["msgs_per_s"],
                          "msgs_per_cpu_s": summary_run["msgs_per_cpu_s_per_process"],
                          "bytes_per_message": float(np.mean([len(p) for _, _, p in
                                                              _summary_payloads(2, 3, fs)]))},
            "latency": latency, "cpus": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else
            os.cpu_count()}


def _raw_payloads(devices: int, batches: int, fs: float) -> list[tuple[str, str, bytes]]:
    """(device, topic, payload) of every device's ``batches`` 0.5 s batches, in time order."""
    step = int(0.5 * fs)
    signal = ToolSignal("hammer_drill", batches * 0.5, fs, 9.0, seed=1).samples()
    t0 = time.time() - batches * 0.5
    out = []
    for i in range(batches):
        xyz = signal[i * step:(i + 1) * step]
        for d in range(devices):
            device = f"w{d + 1}"
            batch = AccelBatch(device, i, t0 + i * 0.5, fs, xyz, WEARABLE_RANGE)
            out.append((device, accel_topic(SITE, device), encode_accel(batch)))
    return out


def _summary_payloads(devices: int, seconds: int, fs: float) -> list[tuple[str, str, bytes]]:
    signal = ToolSignal("grinder", float(seconds), fs, 5.0, seed=2).samples()
    t0 = time.time() - seconds
    per_device = SummaryDevice("w1", fs, WEARABLE_RANGE).feed(signal, t0)
    out = []
    for summary in per_device:
        for d in range(devices):
            device = f"w{d + 1}"
            from dataclasses import replace

            out.append((device, summary_topic(SITE, device), encode_summary(replace(summary, device=device))))
    return out


def _server(devices: set[str], partitions: int, folder: Path) -> NatsServer:
    return NatsServer(SITE, {d: _password(d) for d in devices}, {MONITOR: "monitor-pw"}, partitions=partitions,
                      folder=folder)


def _publish(server: NatsServer, messages: list[tuple[str, str, bytes]]) -> dict:
    """Publish over MQTT 3.1.1 (QoS 1, a connection per device) until the stream holds every message: the
    publisher's row."""
    start, cpu = time.time(), time.process_time()
    with MqttFleet("127.0.0.1", server.mqtt_port, _passwords(messages)) as fleet:
        for device, topic, payload in messages:
            fleet.publish(device, topic, payload)
        fleet.drain(120.0)
    _wait_stored(server, len(messages))
    seconds = time.time() - start
    return {"messages": len(messages), "seconds": seconds, "msgs_per_s": len(messages) / seconds,
            "mb_per_s": sum(len(p) for _, _, p in messages) / seconds / 1e6, "cpu_s": time.process_time() - cpu}


def _password(device: str) -> str:
    """The MQTT password the bench's server gives ``device``."""
    return f"{device}-pw"


def _passwords(messages: list[tuple[str, str, bytes]]) -> dict[str, str]:
    """Each publishing device's MQTT password."""
    return {device: _password(device) for device in dict.fromkeys(device for device, _, _ in messages)}


def _wait_stored(server: NatsServer, count: int, timeout_s: float = 120.0) -> None:
    """Until the HAV stream holds ``count`` messages (the MQTT listener's PUBACK comes before the stream has them)."""
    import asyncio

    import nats

    from bim2rdt.bus.partitions import STREAM

    async def stored() -> int:
        nc = await nats.connect(server.url, user=MONITOR, password="monitor-pw")
        try:
            deadline = time.monotonic() + timeout_s
            while True:
                held = (await nc.jetstream().stream_info(STREAM)).state.messages
                if held >= count or time.monotonic() > deadline:
                    return held
                await asyncio.sleep(0.01)
        finally:
            await nc.close()

    held = asyncio.run(stored())
    if held < count:
        raise RuntimeError(f"the stream holds {held} of {count} messages published")


def _delete_consumers(server: NatsServer, partitions: int) -> None:
    """Forget the partitions' durable consumers, so the next monitors drain the backlog from its start again."""
    import asyncio

    import nats

    from bim2rdt.bus.nats_bus import consumer_name
    from bim2rdt.bus.partitions import STREAM

    async def delete() -> None:
        nc = await nats.connect(server.url, user=MONITOR, password="monitor-pw")
        try:
            for k in range(partitions):
                await nc.jetstream().delete_consumer(STREAM, consumer_name(SITE, k, partitions))
        finally:
            await nc.close()

    asyncio.run(delete())


def _drain_runs(messages: list[tuple[str, str, bytes]], fs: float, rounds: int = ROUNDS
                ) -> tuple[dict, dict[int, dict]]:
    """Publish ``messages`` once into a 2-partition stream; drain it with 1 process, then with 2, ``rounds`` times
    in turn. Each k's row is its median round (by msgs/s), with every round's msgs/s beside it."""
    devices = {device for device, _, _ in messages}
    expected = [sum(1 for d, _, _ in messages if partition_of(SITE, d, 2) == k) for k in range(2)]
    rounds_of: dict[int, list[dict]] = {1: [], 2: []}
    with tempfile.TemporaryDirectory(prefix="bim2rdt-bench-scale-") as folder:
        with _server(devices, 2, Path(folder) / "nats") as server:
            publisher = _publish(server, messages)
            for r in range(rounds):
                for processes, groups in ((1, [[0, 1]]), (2, [[0], [1]])):
                    if r or processes == 2:
                        _delete_consumers(server, 2)
                    stores = Path(folder) / f"run-{processes}-{r}"
                    rounds_of[processes].append(_drain(server, groups, expected, stores, len(messages), fs))
                    shutil.rmtree(stores, ignore_errors=True)  # its pages need not reach the disk during the next
    runs = {}
    for processes, done in rounds_of.items():
        ranked = sorted(done, key=lambda run: run["msgs_per_s"])
        runs[processes] = {**ranked[len(ranked) // 2], "rounds_msgs_per_s": [run["msgs_per_s"] for run in done]}
    return publisher, runs


def _drain(server: NatsServer, groups: list[list[int]], expected: list[int], folder: Path, total: int,
           fs: float) -> dict:
    """Each group of partitions consumed by one process; msgs/s, CPU seconds, the server's CPU, the load."""
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    server_cpu = _cpu_seconds(server.pid)
    results = _consume(server, groups, server.layout.partitions, expected, folder, fs)
    server_cpu = _cpu_seconds(server.pid) - server_cpu
    start, done = min(r["start"] for r in results), max(r["done"] for r in results)
    cpu = [r["cpu_s"] for r in results]
    return {"messages": total, "seconds": done - start, "msgs_per_s": total / (done - start),
            "per_process": [r["delivered"] for r in results], "cpu_s_per_process": cpu,
            "msgs_per_cpu_s_per_process": float(np.mean([r["delivered"] / r["cpu_s"] for r in results])),
            "server_cpu_s": server_cpu, "server_msgs_per_cpu_s": total / server_cpu if server_cpu else None,
            "load_average_1min_before": load}


def _backlog_run(messages: list[tuple[str, str, bytes]], processes: int, fs: float) -> dict:
    """Publish ``messages`` first (one partition per process), then drain them (the summaries' run)."""
    devices = {device for device, _, _ in messages}
    with tempfile.TemporaryDirectory(prefix="bim2rdt-bench-scale-") as folder:
        with _server(devices, processes, Path(folder) / "nats") as server:
            _publish(server, messages)
            expected = [sum(1 for d, _, _ in messages if partition_of(SITE, d, processes) == k)
                        for k in range(processes)]
            return _drain(server, [[k] for k in range(processes)], expected, Path(folder), len(messages), fs)


def _latency_run(devices: int, fs: float, rate: float, seconds: float) -> dict:
    """2 monitors running; the wearables publish at ``rate`` msgs/s in all, evenly spread; publish -> commit."""
    count = max(int(rate * seconds), devices)
    batches = -(-count // devices)
    messages = _raw_payloads(devices, batches, fs)[:count]
    names = {device for device, _, _ in messages}
    with tempfile.TemporaryDirectory(prefix="bim2rdt-bench-scale-") as folder:
        with _server(names, 2, Path(folder) / "nats") as server:
            expected = [sum(1 for d, _, _ in messages if partition_of(SITE, d, 2) == k) for k in range(2)]
            ctx = multiprocessing.get_context("spawn")
            go, queue = ctx.Event(), ctx.Queue()
            workers = [ctx.Process(target=consume_partition, args=(server.url, [k], 2, expected[k], folder, go,
                                                                    queue, True, fs), daemon=True)
                       for k in range(2)]
            for worker in workers:
                worker.start()
            _wait_ready(queue, 2)
            go.set()
            time.sleep(0.5)  # the consumers exist before the first message
            published, cpu = _publish_paced(server, messages, rate)
            results = [queue.get(timeout=300) for _ in workers]
            for worker in workers:
                worker.join(60)
    committed = {key: when for r in results for key, when in r["committed"].items()}
    stages = {key: when for r in results for key, when in r["stages"].items()}
    first = min(published.values())
    steady = [key for key, sent in published.items() if sent - first >= WARMUP_S and key in committed]
    delays = np.array([committed[key] - published[key] for key in steady]) * 1000.0
    timed = [key for key in steady if key in stages]
    parts = {"publish_to_stored": [stages[k][0] - published[k] for k in timed],
             "stored_to_fetched": [stages[k][1] - stages[k][0] for k in timed],
             "fetched_to_committed": [committed[k] - stages[k][1] for k in timed]}
    return {"messages": sum(1 for sent in published.values() if sent - first >= WARMUP_S), "committed": len(delays),
            "warmup_s_left_out": WARMUP_S, "offered_msgs_per_s": rate,
            "offered_fraction_of_one_process": LATENCY_LOAD, "publisher_cpu_s": cpu,
            "p50_ms": float(np.percentile(delays, 50)), "p99_ms": float(np.percentile(delays, 99)),
            "max_ms": float(delays.max()),
            "stages_ms": {name: {"p50": float(np.percentile(v, 50) * 1000), "p99": float(np.percentile(v, 99) * 1000)}
                          for name, v in parts.items() if v}}


def _publish_paced(server: NatsServer, messages: list[tuple[str, str, bytes]], rate: float
                   ) -> tuple[dict, float]:
    """Message i at start + i / rate (each device's in order); ({(device, seq): sent}, publisher CPU seconds)."""
    sent = {}
    seqs = _seqs(messages)
    with MqttFleet("127.0.0.1", server.mqtt_port, _passwords(messages)) as fleet:
        settle()
        start, cpu = time.time(), time.process_time()
        for i, (device, topic, payload) in enumerate(messages):
            wait = start + i / rate - time.time()
            if wait > 0:
                time.sleep(wait)
            sent[(device, seqs[i])] = time.time()
            fleet.publish(device, topic, payload)
        fleet.drain(60.0)
        cpu = time.process_time() - cpu
    gc.unfreeze()
    return sent, cpu


def _seqs(messages: list[tuple[str, str, bytes]]) -> list[int]:
    """Each message's batch seq (its device's count so far: the payloads are made in seq order)."""
    counts: dict[str, int] = {}
    out = []
    for device, _, _ in messages:
        out.append(counts.get(device, 0))
        counts[device] = out[-1] + 1
    return out


def _consume(server: NatsServer, groups: list[list[int]], partitions: int, expected: list[int],
             folder: Path, fs: float) -> list[dict]:
    ctx = multiprocessing.get_context("spawn")
    go, queue = ctx.Event(), ctx.Queue()
    workers = [ctx.Process(target=consume_partition, args=(server.url, group, partitions,
                                                            sum(expected[k] for k in group), str(folder), go, queue,
                                                            False, fs), daemon=True) for group in groups]
    for worker in workers:
        worker.start()
    _wait_ready(queue, len(workers))
    go.set()
    results = [queue.get(timeout=600) for _ in workers]
    for worker in workers:
        worker.join(60)
    return results


def _cpu_seconds(pid: int | None) -> float:
    """CPU seconds (user + system) process ``pid`` has used (Linux /proc; 0 elsewhere)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, TypeError):
        return 0.0


def _wait_ready(queue, count: int) -> None:
    for _ in range(count):
        assert queue.get(timeout=300) == "ready"


def consume_partition(url: str, ks: list[int], n: int, expected: int, folder: str, go, queue, timed: bool,
                      fs: float = 5000.0) -> None:
    """A monitor process of the benchmark: partitions ``ks`` of ``n`` (one consumer each, one monitor) until
    ``expected`` messages are committed."""
    from bim2rdt.bus.nats_bus import FETCH_BATCH, NatsBus
    from bim2rdt.safety.config import MonitorConfig
    from bim2rdt.safety.monitor import HavMonitor

    committed: dict = {}

    class TimedMonitor(HavMonitor):
        def ingest_many(self, batches, now=None):
            batches = list(batches)
            events = super().ingest_many(batches, now)
            if timed:
                when = time.time()
                committed.update({(b.device, b.seq): when for b in batches})
            return events

    from bim2rdt.safety.filters import design_weighting

    design_weighting(fs)  # the process's one-time filter fit (~0.5 s), before the clock starts as in a running monitor
    monitor = TimedMonitor(Path(folder) / f"p{ks[0]}-of-{n}", SECRET,
                           config=MonitorConfig(site=SITE, commit_batches=FETCH_BATCH))
    buses = [NatsBus(url, MONITOR, "monitor-pw", SITE, partition=k, partitions=n) for k in ks]
    stages: dict = {}
    for bus in buses:
        monitor.attach(bus)
        bus.on_fetched = monitor.flush
        if timed:
            _time_stages(bus, stages)
    settle()  # as `hav listen` does before its first message
    queue.put("ready")
    go.wait()
    start, cpu = time.time(), time.process_time()
    for bus in buses:
        bus.connect()
    while sum(bus.delivered for bus in buses) < expected:
        time.sleep(0.002)
    monitor.flush()
    done, cpu = time.time(), time.process_time() - cpu
    for bus in buses:
        bus.close()
    monitor.close()
    queue.put({"start": start, "done": done, "cpu_s": cpu, "delivered": sum(bus.delivered for bus in buses),
               "committed": committed, "stages": stages})


def _time_stages(bus, stages: dict) -> None:
    """Record, per (device, seq), when JetStream stored the message and when the monitor took it from the fetch
    (the k-th message of a device is its batch k: the latency run publishes each device's batches in order)."""
    dispatch, counts = bus._dispatch, {}

    def timed(message) -> None:
        device = message.subject.split(".")[5]
        seq = counts[device] = counts.get(device, -1) + 1
        stages[(device, seq)] = (message.metadata.timestamp.timestamp(), time.time())
        dispatch(message)

    bus._dispatch = timed
