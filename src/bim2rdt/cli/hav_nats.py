"""`bim2rdt hav listen --nats`: one monitor per partition of the NATS path's wearable stream, or a supervisor
that runs all N of them on this host and restarts any that dies."""

from __future__ import annotations

import ctypes
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

from bim2rdt.cli.common import console

RESTART_DELAY_S = 1.0
"""Seconds before a cold restart of a monitor (no standby ready), so a crash loop does not spin."""
POLL_S = 0.2
"""Seconds between the supervisor's looks at its monitors."""
PR_SET_PDEATHSIG = 1
"""Linux prctl option: the signal a process gets when its parent dies."""


def partition_data_dir(settings, partition: int, partitions: int) -> Path:
    """Where partition K of N keeps its SQLite store (each partition its own file, unless hav.store_url names a
    shared one, PostgreSQL) and its identity map."""
    from bim2rdt.config import usable_folder

    return usable_folder(settings.data_dir / "hav" / f"partition-{partition}-of-{partitions}", "BIM2RDT_DATA_DIR")


def listen_partition(settings, url: str, partition: int, partitions: int, duration: float, max_offline: float,
                     sinks: list) -> None:
    """Run the monitor of one partition until stopped; acknowledges each message after its commit."""
    from bim2rdt.bus.nats_bus import FETCH_BATCH, NatsBus
    from bim2rdt.cli.common import stop_requested
    from bim2rdt.cli.hav_output import _leave, _password, watch
    from bim2rdt.safety import BusSink, HavMonitor
    from bim2rdt.safety.heap import settle
    from bim2rdt.safety.persistence import Share
    from bim2rdt.safety.last_delivery import apply_last_delivery

    user = settings.mqtt.username
    hav = settings.hav
    bus = NatsBus(url, user, _password(settings, user), settings.mqtt.site, partition=partition,
                  partitions=partitions, ack_wait_s=hav.ack_wait_s, max_deliver=hav.max_deliver,
                  limits=hav.stream_limits())
    with stop_requested() as stop:
        site = settings.mqtt.site  # a store shared by the partitions (hav.store_url) holds every device's streams
        monitor = HavMonitor(partition_data_dir(settings, partition, partitions), settings.hav.site_secret,
                             sinks + [BusSink(bus, site)],  # one group commit per fetch, however large:
                             settings.hav.monitor_config(commit_batches=max(hav.commit_batches, FETCH_BATCH)),
                             owns=Share(site, partition, partitions))  # its devices, its share of the days
        monitor.attach(bus)
        bus.accepting = lambda: monitor.failure is None  # nothing more is handled or acknowledged after a failure
        bus.on_fetched = monitor.flush  # each fetch is one group commit: no waiting for a group to fill
        bus.on_last_delivery = lambda topic, payload, n: apply_last_delivery(monitor, topic, payload, n)
        settle()  # built: out of the collector's full passes (decision 0028)
        bus.connect()
        console.print(f"partition {partition}/{partitions} of site {site!r} on {url} (pid {os.getpid()}); "
                      f"{len(monitor.queries.devices())} device(s) restored")
        try:
            watch(monitor, bus, duration, max_offline, stop=stop)
        finally:
            _leave(monitor, bus)


def supervise(args: list[str], partitions: int, duration: float) -> None:
    """Start ``bim2rdt hav listen <args> --partition k/N`` for every k, plus one warm standby (imported, waiting
    for a partition on stdin); a monitor that exits is replaced at once by the standby (then a new standby
    starts), so a partition is served again within seconds, not after a cold start. Until stopped or
    ``duration``; then SIGTERM them all (each commits and exits 0)."""
    from bim2rdt.cli.common import stop_requested

    command = [sys.executable, "-m", "bim2rdt", "hav", "listen", *args]
    start = _child_starter(os.getpid())
    children: dict[int, subprocess.Popen] = {}
    standby: subprocess.Popen | None = None
    deadline = time.monotonic() + duration if duration else float("inf")
    with stop_requested() as stop:
        try:
            for k in range(partitions):
                children[k] = start(command + ["--partition", f"{k}/{partitions}"])
            while not stop.is_set() and time.monotonic() < deadline:
                if standby is None or standby.poll() is not None:
                    standby = start(command + ["--standby"], stdin=subprocess.PIPE, text=True)
                for k, child in children.items():
                    if child.poll() is None:
                        continue
                    console.print(f"[yellow]partition {k}/{partitions} exited ({child.returncode}); the standby "
                                  f"takes it[/yellow]")
                    children[k], standby = _hand_over(standby, k, partitions, command, start), None
                    break
                stop.wait(min(POLL_S, max(deadline - time.monotonic(), 0.0)))
        finally:
            _stop_all(list(children.values()) + ([standby] if standby is not None else []))


def _child_starter(supervisor: int) -> Callable[..., subprocess.Popen]:
    """``Popen`` for the supervisor's monitors: on Linux each gets SIGTERM when the supervisor dies (a parent-death
    signal), so a ``kill -9`` of the supervisor leaves no orphan consuming beside the next supervisor's monitors."""
    def die_with_supervisor() -> None:  # in the child, between fork and exec
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
        if os.getppid() != supervisor:  # it died before the signal was armed
            os.kill(os.getpid(), signal.SIGTERM)

    linux = sys.platform.startswith("linux")
    return lambda command, **options: subprocess.Popen(command, preexec_fn=die_with_supervisor if linux else None,
                                                       **options)


def _hand_over(standby: subprocess.Popen | None, k: int, partitions: int, command: list[str],
               start: Callable[..., subprocess.Popen]) -> subprocess.Popen:
    """The standby serving partition ``k`` now, else (it died) a cold start."""
    if standby is not None and standby.poll() is None:
        try:
            standby.stdin.write(f"{k}/{partitions}\n")
            standby.stdin.close()
            return standby
        except OSError:
            pass
    time.sleep(RESTART_DELAY_S)
    return start(command + ["--partition", f"{k}/{partitions}"])


def wait_for_partition() -> str | None:
    """A standby's partition 'K/N', read from stdin (None when the supervisor closed it: exit quietly)."""
    line = sys.stdin.readline().strip()
    return line or None


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
