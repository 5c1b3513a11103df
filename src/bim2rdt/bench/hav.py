"""The HAV benchmark: how many 3-axis 5 kHz wearable streams one core keeps up with, against the bare
``scipy.signal.sosfilt`` floor measured in the same run, and publish-to-event latency through Mosquitto.

Throughput: every stream sends one batch per second of samples; round r hands the monitor all streams' r-th
batches (``ingest_many``: order/dedupe, Wh IIR with carried state, artefact checks, activity tracking, one
SQLite WAL transaction). The floor is ``sosfilt`` alone over the same samples already stacked in one float64
array with carried state: what any Wh IIR must at least cost. Rounds alternate monitor and floor so both see
the same machine load; the first round (stream set-up, activities starting, filter fit) is not timed. Times are
the thread's CPU time (what one core spends; other processes on a shared machine do not count) and figures use
the median round of each pipeline.

Latency: a simulated device publishes 0.1 s batches (QoS 1; 3 s of hammer drilling, 3 s pause, repeated) to a
real Mosquitto with the shipped config; the monitor, subscribed through its own client, ingests each; latency is
publish call to ingest done (events emitted), per message, and separately for the messages that produced events
(activity start/end, predictions every second of activity).
"""

from __future__ import annotations

import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import scipy.signal

from bim2rdt.bus.payloads import AccelBatch, encode_accel
from bim2rdt.bus.topics import accel_topic, wearable_pattern
from bim2rdt.safety.filters import design_weighting
from bim2rdt.safety.config import MonitorConfig
from bim2rdt.safety.monitor import HavMonitor
from bim2rdt.sim.vibration import WEARABLE_RANGE, tool_vibration

DISTINCT_SIGNALS = 12
TOOLS = ("hammer_drill", "grinder", "breaker")


def run_throughput(streams: int = 2000, seconds: int = 6, fs: float = 5000.0, keep_raw: bool = False,
                   tick: Callable[[], None] | None = None) -> dict:
    """Time the monitor and the sosfilt floor over ``seconds`` one-second rounds of ``streams`` streams."""
    n = int(fs)
    signals = [tool_vibration(TOOLS[k % 3], seconds + 1, fs, seed=k) for k in range(DISTINCT_SIGNALS)]
    sos, t0 = design_weighting(fs).sos, 1.7e9
    zi = np.zeros((sos.shape[0], 3 * streams, 2))
    ours, floor = [], []
    with tempfile.TemporaryDirectory(prefix="bim2rdt-bench-") as folder:
        config = MonitorConfig(raw_retention_s=7 * 86400.0 if keep_raw else 0.0)
        monitor = HavMonitor(Path(folder), "bench", [], config)
        for r in range(seconds + 1):
            batch = [AccelBatch(f"d{i}", r, t0 + r, fs, signals[i % DISTINCT_SIGNALS][r * n:(r + 1) * n],
                                WEARABLE_RANGE, t0 + r + 1.02) for i in range(streams)]
            stacked = np.concatenate([b.xyz.T for b in batch], dtype=np.float64)
            start = time.thread_time()
            _, zi = scipy.signal.sosfilt(sos, stacked, axis=-1, zi=zi)
            middle = time.thread_time()
            monitor.ingest_many(batch, now=t0 + r + 1.02)
            end = time.thread_time()
            if r > 0:
                floor.append(middle - start)
                ours.append(end - middle)
            if tick is not None:
                tick()
        monitor.close()
    ours_s, floor_s = float(np.median(ours)), float(np.median(floor))
    return {"streams": streams, "seconds": seconds, "fs": fs, "keep_raw": keep_raw,
            "monitor_round_s": ours_s, "floor_round_s": floor_s, "monitor_rounds_s": ours, "floor_rounds_s": floor,
            "monitor_streams_realtime": streams / ours_s, "floor_streams_realtime": streams / floor_s,
            "ratio_to_floor": ours_s / floor_s}


def run_latency(messages: int = 200, rate_hz: float = 20.0, fs: float = 5000.0, batch_s: float = 0.1,
                tick: Callable[[], None] | None = None) -> dict:
    """Publish-to-ingest latency (ms) of ``messages`` batches through a real Mosquitto, p50/p99/max."""
    from bim2rdt.bus.broker import MosquittoBroker
    from bim2rdt.bus.mqtt import MqttBus

    users = {"monitor": "bench-monitor", "w1": "bench-w1"}
    done, produced, finished = [], [], threading.Event()
    with tempfile.TemporaryDirectory(prefix="bim2rdt-bench-") as folder, MosquittoBroker(users) as broker:
        config = MonitorConfig(site="bench", predict_every_s=1.0, commit_delay_s=0.0)  # events on many messages
        monitor = HavMonitor(Path(folder), "bench", [], config)

        def on_accel(topic: str, payload: bytes) -> None:
            produced.append(len(monitor.ingest_payload(topic, payload)))
            done.append(time.perf_counter())
            if len(done) >= messages:
                finished.set()

        listener = MqttBus("127.0.0.1", broker.port, username="monitor", password=users["monitor"])
        listener.subscribe(wearable_pattern("bench", "accel"), on_accel)
        listener.connect()
        device = MqttBus("127.0.0.1", broker.port, username="w1", password=users["w1"]).connect()
        published = _publish_paced(device, messages, rate_hz, fs, batch_s, tick)
        finished.wait(30.0)
        device.close()
        listener.close()
        monitor.close()
    return _latency_summary(np.array(published), np.array(done), np.array(produced))


def _publish_paced(device, messages: int, rate_hz: float, fs: float, batch_s: float,
                   tick: Callable[[], None] | None) -> list[float]:
    """A wearable's batches at ``rate_hz`` (3 s of hammer drilling, 3 s pause, ...); returns publish times."""
    cycle = np.concatenate([tool_vibration("idle", 3.0, fs), tool_vibration("hammer_drill", 3.0, fs)])
    signal = np.tile(cycle, (int(np.ceil(messages * batch_s / 6.0)) + 1, 1))
    step, t0, published = int(batch_s * fs), time.time(), []
    for seq in range(messages):
        batch = AccelBatch("w1", seq, t0 + seq * batch_s, fs, signal[seq * step:(seq + 1) * step], WEARABLE_RANGE)
        payload = encode_accel(batch)
        published.append(time.perf_counter())
        device.publish(accel_topic("bench", "w1"), payload, qos=1)
        if tick is not None:
            tick()
        time.sleep(max(0.0, published[0] + (seq + 1) / rate_hz - time.perf_counter()))
    return published


def _latency_summary(published: np.ndarray, done: np.ndarray, produced: np.ndarray) -> dict:
    count = min(published.size, done.size)
    latency = (done[:count] - published[:count]) * 1000.0
    with_events = latency[produced[:count] > 0]
    return {"messages": int(count), "p50_ms": float(np.percentile(latency, 50)),
            "p99_ms": float(np.percentile(latency, 99)), "max_ms": float(latency.max()),
            "event_messages": int(with_events.size),
            "event_p50_ms": float(np.percentile(with_events, 50)) if with_events.size else None,
            "event_p99_ms": float(np.percentile(with_events, 99)) if with_events.size else None}
