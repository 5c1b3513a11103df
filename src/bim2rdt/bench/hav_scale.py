"""`bench hav --scale`: the NATS path's monitor processes, measured against themselves in one run.

Throughput: a backlog of raw batches (0.5 s, 3 axes int16 at ``fs``; every wearable's) is published over MQTT
3.1.1 to a private nats-server before any monitor runs; then 1, and on a fresh server 2, monitor processes (one
partition each, pinned to one CPU each where the OS allows) consume it: durable pull consumers, each fetch one
group commit into the process's own SQLite store, acknowledged after it. msgs/s = backlog / (last process done -
start signal). Summaries: the same with a backlog of 1 Hz on-device summaries and one process.

Latency: with 2 monitor processes running, the wearables publish in real time (each a batch every 0.5 s); per
batch, publish call (device side) to its commit in a monitor (the moment its exposure and events exist),
p50/p99 over all batches after the first ``WARMUP_ROUNDS`` rounds.
"""

from __future__ import annotations

import multiprocessing
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from bim2rdt.bus.mqtt import MqttBus
from bim2rdt.bus.nats_broker import NatsServer
from bim2rdt.bus.partitions import partition_of
from bim2rdt.bus.payloads import AccelBatch, encode_accel
from bim2rdt.bus.summaries import encode_summary, summary_topic
from bim2rdt.bus.topics import accel_topic
from bim2rdt.safety.summary import SummaryDevice
from bim2rdt.sim.vibration import WEARABLE_RANGE, ToolSignal

SITE, SECRET, MONITOR = "bench", "bench-secret", "monitor"
TARGET_SCALING = 1.7
WARMUP_ROUNDS = 4
"""Half-second rounds of the latency run left out of its figures: the monitors connecting and creating their
consumers while the first batches are already published."""
TARGET_P99_MS = 100.0


def targets(result: dict) -> dict[str, bool]:
    return {"two_processes_ge_1_7x_one": result["throughput"]["scaling"] >= TARGET_SCALING,
            "latency_p99_le_100ms": result["latency"]["p99_ms"] <= TARGET_P99_MS}


def run_scale(devices: int = 100, batches: int = 60, fs: float = 5000.0, summaries: int = 200,
              latency_s: float = 10.0, tick=None) -> dict:
    """Throughput with 1 and 2 processes, summaries with 1, latency with 2 (see the module docstring)."""
    tick = tick or (lambda: None)
    raw = _raw_payloads(devices, batches, fs)
    runs = {}
    for processes in (1, 2):
        runs[processes] = _backlog_run(raw, processes)
        tick()
    summary_run = _backlog_run(_summary_payloads(devices, summaries, fs), 1)
    tick()
    latency = _latency_run(devices, fs, latency_s)
    tick()
    one, two = runs[1]["msgs_per_s"], runs[2]["msgs_per_s"]
    bytes_per_batch = float(np.mean([len(p) for _, _, p in raw]))
    return {"throughput": {"devices": devices, "messages": len(raw), "fs": fs, "bytes_per_message": bytes_per_batch,
                           "one_process_msgs_per_s": one, "two_processes_msgs_per_s": two, "scaling": two / one,
                           "per_process": runs},
            "summaries": {"messages": summary_run["messages"], "msgs_per_s_per_process": summary_run["msgs_per_s"],
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
    return NatsServer(SITE, {d: f"{d}-pw" for d in devices}, {MONITOR: "monitor-pw"}, partitions=partitions,
                      folder=folder)


def _publish(server: NatsServer, messages: list[tuple[str, str, bytes]]) -> None:
    buses = {}
    try:
        for device, topic, payload in messages:
            bus = buses.get(device)
            if bus is None:
                bus = buses[device] = MqttBus("127.0.0.1", server.mqtt_port, client_id=device, username=device,
                                              password=f"{device}-pw", mqtt_version=3).connect()
            bus.publish(topic, payload, qos=1)
        for bus in buses.values():
            bus.drain(120.0)
    finally:
        for bus in buses.values():
            bus.close()


def _backlog_run(messages: list[tuple[str, str, bytes]], processes: int) -> dict:
    """Publish ``messages`` first, then let ``processes`` monitors consume them; msgs/s and per-process counts."""
    devices = {device for device, _, _ in messages}
    with tempfile.TemporaryDirectory(prefix="bim2rdt-bench-scale-") as folder:
        with _server(devices, processes, Path(folder) / "nats") as server:
            _publish(server, messages)
            expected = [sum(1 for d, _, _ in messages if partition_of(SITE, d, processes) == k)
                        for k in range(processes)]
            server_cpu = _cpu_seconds(server.pid)
            results = _consume(server, processes, expected, Path(folder), None)
            server_cpu = _cpu_seconds(server.pid) - server_cpu
    start = min(r["start"] for r in results)
    done = max(r["done"] for r in results)
    return {"messages": len(messages), "seconds": done - start, "msgs_per_s": len(messages) / (done - start),
            "per_process": [r["delivered"] for r in results],
            "cpu_s_per_process": [r["cpu_s"] for r in results],
            "msgs_per_cpu_s": len(messages) / sum(r["cpu_s"] for r in results),
            "server_cpu_s": server_cpu, "server_msgs_per_cpu_s": len(messages) / server_cpu if server_cpu else None}


def _latency_run(devices: int, fs: float, seconds: float) -> dict:
    """2 monitors running; the wearables publish batches in real time; publish -> commit per batch."""
    batches = int(seconds / 0.5)
    messages = _raw_payloads(devices, batches, fs)
    names = {device for device, _, _ in messages}
    with tempfile.TemporaryDirectory(prefix="bim2rdt-bench-scale-") as folder:
        with _server(names, 2, Path(folder) / "nats") as server:
            expected = [sum(1 for d, _, _ in messages if partition_of(SITE, d, 2) == k) for k in range(2)]
            ctx = multiprocessing.get_context("spawn")
            go, queue = ctx.Event(), ctx.Queue()
            workers = [ctx.Process(target=consume_partition, args=(server.url, k, 2, expected[k], folder, go,
                                                                    queue, True)) for k in range(2)]
            for worker in workers:
                worker.start()
            _wait_ready(queue, 2)
            go.set()
            published = _publish_paced(server, messages, devices)
            results = [queue.get(timeout=300) for _ in workers]
            for worker in workers:
                worker.join(60)
    committed = {key: when for r in results for key, when in r["committed"].items()}
    steady = {key: sent for key, sent in published.items() if key[1] >= WARMUP_ROUNDS}
    delays = np.array([committed[key] - sent for key, sent in steady.items() if key in committed]) * 1000.0
    return {"messages": len(steady), "committed": len(delays), "warmup_rounds_left_out": WARMUP_ROUNDS, "rate_msgs_per_s": devices * 2.0,
            "p50_ms": float(np.percentile(delays, 50)), "p99_ms": float(np.percentile(delays, 99)),
            "max_ms": float(delays.max())}


def _publish_paced(server: NatsServer, messages: list[tuple[str, str, bytes]], devices: int) -> dict:
    """Each device's batches every 0.5 s (all devices in one round per half second); {(device, seq): sent}."""
    import json

    buses = {}
    sent = {}
    try:
        for device, _, _ in messages[:devices]:
            buses[device] = MqttBus("127.0.0.1", server.mqtt_port, client_id=device, username=device,
                                    password=f"{device}-pw", mqtt_version=3).connect()
        start = time.time()
        for i in range(0, len(messages), devices):
            due = start + (i // devices) * 0.5
            if due > time.time():
                time.sleep(due - time.time())
            for device, topic, payload in messages[i:i + devices]:
                seq = json.loads(payload[6:6 + int.from_bytes(payload[4:6], "little")])["seq"]
                sent[(device, seq)] = time.time()
                buses[device].publish(topic, payload, qos=1)
        for bus in buses.values():
            bus.drain(60.0)
    finally:
        for bus in buses.values():
            bus.close()
    return sent


def _consume(server: NatsServer, processes: int, expected: list[int], folder: Path, latency) -> list[dict]:
    ctx = multiprocessing.get_context("spawn")
    go, queue = ctx.Event(), ctx.Queue()
    workers = [ctx.Process(target=consume_partition, args=(server.url, k, processes, expected[k], str(folder), go,
                                                            queue, False)) for k in range(processes)]
    for worker in workers:
        worker.start()
    _wait_ready(queue, processes)
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


def consume_partition(url: str, k: int, n: int, expected: int, folder: str, go, queue, timed: bool) -> None:
    """A monitor process of the benchmark: partition ``k`` of ``n`` until ``expected`` messages are committed."""
    from bim2rdt.bus.nats_bus import NatsBus
    from bim2rdt.safety.config import MonitorConfig
    from bim2rdt.safety.monitor import HavMonitor

    if hasattr(os, "sched_setaffinity"):
        cpus = sorted(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {cpus[k % len(cpus)]})
    committed: dict = {}

    class TimedMonitor(HavMonitor):
        def ingest_many(self, batches, now=None):
            batches = list(batches)
            events = super().ingest_many(batches, now)
            if timed:
                when = time.time()
                committed.update({(b.device, b.seq): when for b in batches})
            return events

    monitor = TimedMonitor(Path(folder) / f"p{k}-of-{n}", SECRET, config=MonitorConfig(site=SITE))
    bus = NatsBus(url, MONITOR, "monitor-pw", SITE, partition=k, partitions=n)
    monitor.attach(bus)
    bus.on_fetched = monitor.flush
    queue.put("ready")
    go.wait()
    start, cpu = time.time(), time.process_time()
    bus.connect()
    while bus.delivered < expected:
        time.sleep(0.002)
    monitor.flush()
    done, cpu = time.time(), time.process_time() - cpu
    bus.close()
    monitor.close()
    queue.put({"start": start, "done": done, "cpu_s": cpu, "delivered": bus.delivered, "committed": committed})
