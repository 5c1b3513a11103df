"""`bim2rdt hav listen --nats`: one monitor per partition of the NATS path's wearable stream, or a supervisor
that runs all N of them on this host and restarts any that dies."""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from pathlib import Path

from bim2rdt.cli.common import console

RESTART_DELAY_S = 1.0
"""Seconds between a monitor's death and its restart (a crash loop does not spin)."""


def partition_data_dir(settings, partition: int, partitions: int) -> Path:
    """Where partition K of N keeps its SQLite store: each partition owns its own file."""
    from bim2rdt.config import usable_folder

    return usable_folder(settings.data_dir / "hav" / f"partition-{partition}-of-{partitions}", "BIM2RDT_DATA_DIR")


def listen_partition(settings, url: str, partition: int, partitions: int, duration: float, max_offline: float,
                     sinks: list) -> None:
    """Run the monitor of one partition until stopped; acknowledges each message after its commit."""
    from bim2rdt.bus.nats_bus import NatsBus
    from bim2rdt.cli.common import stop_requested
    from bim2rdt.cli.hav import _leave, _password, watch
    from bim2rdt.cli.hav_output import open_monitor
    from bim2rdt.safety import BusSink

    user = settings.mqtt.username
    bus = NatsBus(url, user, _password(settings, user), settings.mqtt.site, partition=partition,
                  partitions=partitions, ack_wait_s=settings.hav.ack_wait_s, max_deliver=settings.hav.max_deliver)
    with stop_requested() as stop:
        monitor = open_monitor(settings, sinks + [BusSink(bus, settings.mqtt.site)],
                               data_dir=partition_data_dir(settings, partition, partitions))
        monitor.attach(bus)
        bus.accepting = lambda: monitor.failure is None  # nothing more is handled or acknowledged after a failure
        bus.connect()
        console.print(f"partition {partition}/{partitions} of site {settings.mqtt.site!r} on {url}; "
                      f"{len(monitor.devices())} device(s) restored")
        try:
            watch(monitor, bus, duration, max_offline, stop=stop)
        finally:
            _leave(monitor, bus)


def supervise(args: list[str], partitions: int, duration: float) -> None:
    """Start ``bim2rdt hav listen <args> --partition k/N`` for every k; restart one that exits (after
    ``RESTART_DELAY_S``) until stopped or ``duration``; then SIGTERM them all (each commits and exits 0)."""
    from bim2rdt.cli.common import stop_requested

    command = [sys.executable, "-m", "bim2rdt", "hav", "listen", *args]
    children: dict[int, subprocess.Popen] = {}
    deadline = time.monotonic() + duration if duration else float("inf")
    with stop_requested() as stop:
        try:
            while not stop.is_set() and time.monotonic() < deadline:
                for k in range(partitions):
                    child = children.get(k)
                    if child is None or child.poll() is not None:
                        if child is not None:
                            console.print(f"[yellow]partition {k}/{partitions} exited ({child.returncode}); "
                                          f"restarting[/yellow]")
                        children[k] = subprocess.Popen(command + ["--partition", f"{k}/{partitions}"])
                stop.wait(min(RESTART_DELAY_S, max(deadline - time.monotonic(), 0.0)))
        finally:
            _stop_all(list(children.values()))


def _stop_all(children: list[subprocess.Popen], timeout_s: float = 30.0) -> None:
    for child in children:
        if child.poll() is None:
            child.terminate()
    waiters = [threading.Thread(target=_wait_or_kill, args=(child, timeout_s)) for child in children]
    for waiter in waiters:
        waiter.start()
    for waiter in waiters:
        waiter.join()


def _wait_or_kill(child: subprocess.Popen, timeout_s: float) -> None:
    try:
        child.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        child.kill()
        child.wait()
