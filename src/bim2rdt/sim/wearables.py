"""Simulated wearables on a bus: each worker's device publishes its status and acceleration batches.

A worker's day is a plan of (tool, seconds) pieces with pauses; each tool piece is announced by a retained
status message ``{"online": true, "worker", "tool", "position", "zone", "boot"}`` (the device's last will sets
``{"online": false}``), then its samples go out as QoS 1 batches with (device, seq, device time). Devices are
interleaved in time order; ``speed`` 1 paces them in real time, 0 publishes as fast as the bus takes them.

``boot`` names the device's power-up (the hex of its power-up time in ms, unique per device as a random id
would be). A ``("reboot", seconds)`` piece restarts the device: its last will goes out (offline), it is off for
``seconds``, then it powers up with a new boot id, which it announces at once, and counts seq from 0 again. A
plan on a ``boot`` clock stamps samples with seconds since power-up, as a wearable without wall time does: after
a reboot its times repeat the first power-up's exactly, which only the new boot id tells from a replay.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace

import numpy as np

from bim2rdt.bus.payloads import encode_accel
from bim2rdt.bus.summaries import encode_summary, summary_topic
from bim2rdt.bus.topics import accel_topic, status_topic
from bim2rdt.safety.summary import SummaryDevice
from bim2rdt.sim.vibration import TOOLS, WEARABLE_RANGE, ToolSignal, batches

TOOL_ORDER = ("grinder", "hammer_drill", "breaker")
PAUSE_S = 30.0
REBOOT = "reboot"
"""A plan piece that restarts the device (off for its seconds): new boot id, seq from 0, a boot clock from 0."""
REBOOT_DOWN_S = 10.0
"""Seconds a restarting device is off, by default."""


@dataclass(frozen=True)
class WorkerPlan:
    """A simulated worker: device id, worker id, work zone, (tool, seconds) pieces ('idle' = pause) and how
    hard the worker's tools shake relative to the typical magnitude (``intensity``)."""

    device: str
    worker: str
    zone: str | None
    pieces: tuple[tuple[str, float], ...]
    intensity: float = 1.0
    clock: str = "wall"
    """'wall': device times are UTC epoch seconds; 'boot': seconds since the device powered up (no wall time)."""


def default_plans(workers: int, minutes: float, zone: str | None = None) -> list[WorkerPlan]:
    """Each worker uses the three tools in a rotated order, splitting ``minutes`` with 30 s pauses."""
    plans = []
    for k in range(workers):
        tools = TOOL_ORDER[k % 3:] + TOOL_ORDER[:k % 3]
        each = max(minutes * 60.0 / 3 - PAUSE_S, 10.0)
        pieces = [("idle", 5.0)]
        for tool in tools:
            pieces += [(tool, each), ("idle", PAUSE_S)]
        plans.append(WorkerPlan(f"w{k + 1}", f"worker-{k + 1:03d}", zone, tuple(pieces), 0.9 + 0.15 * (k % 4)))
    return plans


def with_reboot(plan: WorkerPlan, after_s: float, down_s: float = REBOOT_DOWN_S) -> WorkerPlan:
    """``plan`` with its device restarting once ``after_s`` seconds into it (the piece running then is split)."""
    pieces, elapsed = [], 0.0
    for piece, seconds in plan.pieces:
        if elapsed <= after_s < elapsed + seconds:
            cut = after_s - elapsed
            pieces += [(piece, cut)] * (cut > 0) + [(REBOOT, down_s), (piece, seconds - cut)]
        else:
            pieces.append((piece, seconds))
        elapsed += seconds
    return replace(plan, pieces=tuple(pieces))


def status_payload(plan: WorkerPlan, tool: str, online: bool = True, boot: str | None = None) -> bytes:
    """The retained status: online with the worker, tool and boot id, or the last will's ``{"online": false}``."""
    body = {"online": online, "worker": plan.worker, "tool": tool, "position": "handle", "zone": plan.zone}
    if boot is not None:
        body["boot"] = boot
    return json.dumps(body if online else {"online": False}).encode()


def boot_id(power_up: float) -> str:
    """The id a device draws at power-up (wall time ``power_up``, s): the hex of that time in ms."""
    return f"{round(power_up * 1000.0):x}"


def timed_messages(plans: list[WorkerPlan], site: str, fs: float, t0: float, batch_s: float = 0.5,
                   seed: int = 0, summaries: bool = False) -> Iterator[tuple[float, str, str, bytes, bool]]:
    """(wall time, device, topic, payload, retain) of every device's messages, in time order (on a wall clock
    the wall time is the device time). ``summaries``: the devices weigh their own samples and send one on-device
    summary per second (safety.summary) instead of raw batches."""
    streams = [_device_messages(plan, site, fs, t0, batch_s, seed + i, summaries) for i, plan in enumerate(plans)]
    heads = [next(s, None) for s in streams]
    while any(h is not None for h in heads):
        i = min((k for k, h in enumerate(heads) if h is not None), key=lambda k: heads[k][0])
        yield heads[i]
        heads[i] = next(streams[i], None)


def _device_messages(plan: WorkerPlan, site: str, fs: float, t0: float, batch_s: float,
                     seed: int, summaries: bool = False) -> Iterator[tuple[float, str, str, bytes, bool]]:
    """(wall time, device, topic, payload, retain) of one device; the device powers up at ``t0``."""
    when, seq, tool, power_up = t0, 0, plan.pieces[0][0], t0
    status = status_topic(site, plan.device)
    weigher = SummaryDevice(plan.device, fs, WEARABLE_RANGE) if summaries else None
    for i, (piece, seconds) in enumerate(plan.pieces):
        if piece == REBOOT:  # its last will, then a new power-up announced at once
            yield when, plan.device, status, status_payload(plan, tool, online=False), True
            when += seconds
            seq, power_up = 0, when
            if weigher is not None:
                weigher.restart(0)
            yield when, plan.device, status, status_payload(plan, _named(tool), boot=boot_id(power_up)), True
            continue
        if piece != "idle":
            tool = piece
            yield when, plan.device, status, status_payload(plan, tool, boot=boot_id(power_up)), True
        signal = _piece_signal(plan, piece, seconds, fs, seed * 100 + i)
        start = when - power_up if plan.clock == "boot" else when
        if weigher is not None:
            for summary in weigher.feed(signal.samples(), start):
                yield when + summary.end_time - start, plan.device, summary_topic(site, plan.device), \
                    encode_summary(summary), False
            when += signal.n / fs
            continue
        for batch in batches(plan.device, signal, fs, start, batch_s, seq):
            yield when + batch.device_time - start, plan.device, accel_topic(site, plan.device), encode_accel(batch), \
                False
            seq = batch.seq + 1
        when += signal.n / fs
    yield when, plan.device, status, status_payload(plan, tool, online=False), True


def _named(tool: str) -> str:
    """The tool a status names: the one in hand, 'unknown' before the first."""
    return "unknown" if tool == "idle" else tool


def publish_plans(bus_for: Callable[[str], object], plans: list[WorkerPlan], site: str, fs: float,
                  batch_s: float = 0.5, speed: float = 0.0, t0: float | None = None,
                  tick: Callable[[float], None] | None = None, summaries: bool = False) -> int:
    """Publish every plan through ``bus_for(device)`` (QoS 1); returns the number of messages sent."""
    start_wall, t0 = time.time(), time.time() if t0 is None else t0
    sent = 0
    for when, device, topic, payload, retain in timed_messages(plans, site, fs, t0, batch_s, summaries=summaries):
        if speed > 0:
            delay = (when - t0) / speed - (time.time() - start_wall)
            if delay > 0:
                time.sleep(delay)
        bus_for(device).publish(topic, payload, qos=1, retain=retain)
        sent += 1
        if tick is not None:
            tick(when - t0)
    return sent


def plan_seconds(plan: WorkerPlan) -> float:
    return float(sum(seconds for _, seconds in plan.pieces))


def plan_signal(plan: WorkerPlan, fs: float, seed: int = 0) -> np.ndarray:
    """The (n, 3) samples of a whole plan (the same ones :func:`timed_messages` sends for seed ``seed``; a reboot
    sends none)."""
    return np.concatenate([_piece_signal(plan, piece, seconds, fs, seed * 100 + i).samples()
                           for i, (piece, seconds) in enumerate(plan.pieces) if piece != REBOOT])


def _piece_signal(plan: WorkerPlan, tool: str, seconds: float, fs: float, seed: int) -> ToolSignal:
    return ToolSignal(tool, seconds, fs, TOOLS[tool].a_hv * plan.intensity, seed=seed)


def run_in_process(plans: list[WorkerPlan], monitor, site: str, fs: float, speed: float = 0.0,
                   tick: Callable[[float], None] | None = None, summaries: bool = False) -> int:
    """Publish every plan on an in-process bus that ``monitor`` (a :class:`~bim2rdt.safety.HavMonitor`) is
    attached to, then commit what waits; returns the number of messages sent."""
    from bim2rdt.bus.local import LocalBus

    bus = LocalBus().connect()
    monitor.attach(bus)
    sent = publish_plans(lambda device: bus, plans, site, fs, speed=speed, tick=tick, summaries=summaries)
    monitor.flush()
    return sent


def run_over_mqtt(plans: list[WorkerPlan], site: str, fs: float, host: str, port: int,
                  password_of: Callable[[str], str], speed: float = 0.0,
                  tick: Callable[[float], None] | None = None, mqtt_version: int = 5,
                  summaries: bool = False) -> int:
    """Publish every plan to a broker, each device logged in as itself (``password_of(device)``) with its
    retained offline status as last will; returns the number of messages sent. ``mqtt_version`` 3: MQTT 3.1.1
    (nats-server's MQTT listener)."""
    from bim2rdt.bus.mqtt import MqttBus

    buses = {}
    try:
        for plan in plans:
            will = (status_topic(site, plan.device), status_payload(plan, "", False))
            buses[plan.device] = MqttBus(host, port, client_id=plan.device, username=plan.device,
                                         password=password_of(plan.device), will=will,
                                         mqtt_version=mqtt_version).connect()
        sent = publish_plans(buses.__getitem__, plans, site, fs, speed=speed, tick=tick, summaries=summaries)
        for bus in buses.values():
            bus.drain(60.0)  # a close drops what the broker has not acknowledged yet
        return sent
    finally:
        for bus in buses.values():
            bus.close()
