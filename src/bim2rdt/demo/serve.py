"""``bim2rdt serve``'s wiring: the server (``bim2rdt.server``) over a twin and a HAV monitor.

By default it is the embedded demo, live: the site day's twin (run first if its outputs are absent) and a HAV
monitor fed by simulated wearables on an in-process bus, sped up so a newcomer sees the gauges move: at the
default 20x, the breaker worker crosses the EAV within a minute of wall time and the ELV within three. With a
twin URL it serves that twin; with a broker it takes real wearables. The server never imports this (it sits
below sim and demo): the wiring lives here, above both.
"""

from __future__ import annotations

import logging
import math
import shutil
import signal
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from bim2rdt.sim.wearables import WorkerPlan

LIVE_SPEED = 20.0
"""Device seconds per wall second of the live wearables."""
FS_HZ = 2500.0
"""Hz: covers every Wh band to 1 kHz (covered_band), at half the cost of 5 kHz."""
TICK_S = 0.1
"""How often the monitor is ticked: group commits that waited long enough, overdue gaps."""


def live_plans(zone: str | None) -> list[WorkerPlan]:
    """Three workers: a breaker (~15 m/s^2: EAV after 800 s of tool time, ELV after 3200 s), a hammer drill then
    a grinder, and a grinder alone (EAV after two hours)."""
    return [WorkerPlan("w1", "worker-001", zone, (("idle", 5.0), ("breaker", 1500.0), ("idle", 60.0),
                                                  ("breaker", 3000.0), ("idle", 30.0))),
            WorkerPlan("w2", "worker-002", zone, (("idle", 20.0), ("hammer_drill", 1800.0), ("idle", 60.0),
                                                  ("grinder", 3600.0), ("idle", 30.0))),
            WorkerPlan("w3", "worker-003", zone, (("idle", 40.0), ("grinder", 7200.0), ("idle", 30.0)))]


def demo_clock(twin, speed: float = LIVE_SPEED):
    """The demo's one clock: its simulated site day. It goes on from the twin's last record (the robots' route
    and the site day's HAV), at ``speed``, from now on the wall clock; the live wearables and the page's header
    run on it."""
    from bim2rdt.server.clock import SourceClock

    times = [event.time for event in twin.events()]
    origin = float(math.ceil(max(times))) if times else time.time()
    return SourceClock(origin_s=origin, speed=speed, wall_origin_s=time.time())


def ensure_site_day(out_dir: Path, settings, tick: Callable[[str], None] = lambda stage: None) -> tuple[Path, Path]:
    """(site.ifc, twin.db) of the demo in ``out_dir``; runs the site day (with ``settings``' mission, registration
    and twin sections) first when either is absent."""
    site, twin_db = out_dir / "site.ifc", out_dir / "twin.db"
    if not (site.is_file() and twin_db.is_file()):
        from bim2rdt.demo.site_day import run_site_day

        day = run_site_day(out_dir, mission_config=settings.mission, icp=settings.registration,
                           twin_config=settings.twin, tick=tick, localization=settings.localization,
                           perception=settings.perception)
        day.twin.close()
    return site, twin_db


@dataclass
class LiveWearables:
    """Publishes ``plans`` on ``bus`` at ``speed`` from a thread, and ticks ``monitor``; ``stop()`` ends both."""

    monitor: object
    bus: object
    plans: list[WorkerPlan]
    site: str
    speed: float = LIVE_SPEED
    fs: float = FS_HZ
    t0: float | None = None
    """UTC s of the plans' start on the demo's clock (None: the wall clock now)."""

    def __post_init__(self) -> None:
        self._stop = threading.Event()
        self._threads = [threading.Thread(target=self._publish, name="live-wearables", daemon=True),
                         threading.Thread(target=self._tick, name="live-monitor-tick", daemon=True)]

    def start(self) -> LiveWearables:
        for thread in self._threads:
            thread.start()
        return self

    def start_ticking(self) -> LiveWearables:
        """Only tick the monitor (its input is a broker)."""
        self._threads[1].start()
        self._threads = self._threads[1:]
        return self

    def stop(self) -> None:
        self._stop.set()
        for thread in self._threads:
            thread.join(5)

    def _publish(self) -> None:
        from bim2rdt.sim.wearables import publish_plans

        class Stopped(Exception):
            pass

        def tick(_elapsed: float) -> None:
            if self._stop.is_set():
                raise Stopped

        try:
            publish_plans(lambda device: self.bus, self.plans, self.site, self.fs, speed=self.speed, t0=self.t0,
                          tick=tick)
        except Stopped:
            pass

    def _tick(self) -> None:
        while not self._stop.wait(TICK_S):
            self.monitor.tick()


REFRESH_S = 2.0
"""Seconds between a store reader's reloads (serve --nats)."""


class StoreReader:
    """Reloads a monitor from the store the partitions' monitors write, every ``REFRESH_S`` (it ingests nothing)."""

    def __init__(self, monitor):
        self.monitor, self._stop = monitor, threading.Event()
        self._thread = threading.Thread(target=self._run, name="hav-store-reader", daemon=True)

    def start(self) -> StoreReader:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(5)

    def _run(self) -> None:
        while not self._stop.wait(REFRESH_S):
            try:
                self.monitor.refresh()
            except Exception:  # a store hiccup: the next refresh tries again; the page keeps the last figures
                logging.getLogger(__name__).exception("refreshing from the shared store failed")


def fresh_folder(path: Path) -> Path:
    """An empty folder at ``path`` (the live monitor's store: it simulates a new day each time). Never the audit
    log's folder: nothing may remove an audit log."""
    shutil.rmtree(path, ignore_errors=True)
    path.mkdir(parents=True)
    return path


class LiveServe:
    """The server, its twin, its monitor and its input, started on enter and closed on exit; ``url``, ``tokens``
    ({role: token} generated for this run: always a viewer, with ``all_roles`` a safety and an admin too) and
    ``source`` (what feeds the monitor) once started."""

    def __init__(self, settings, config, out_dir: Path, twin_url: str | None, ifc: Path | None,
                 mqtt: tuple[str, int] | None, speed: float = LIVE_SPEED, all_roles: bool = False,
                 progress: Callable[[str], None] = lambda stage: None, nats: str | None = None):
        """``nats``: the NATS path's URL; the monitor is then a reader of the partitions' shared store
        (``hav.store_url``), refreshed every ``REFRESH_S``: it shows every partition's workers."""
        self.settings, self.config, self.out_dir = settings, config, Path(out_dir)
        self.nats = nats
        self.twin_url, self.ifc, self.mqtt, self.speed = twin_url, ifc, mqtt, speed
        self.all_roles, self.progress = all_roles, progress
        self.demo = twin_url is None
        self.started = False
        self._closers: list[Callable[[], None]] = []

    def start(self) -> LiveServe:
        """Open the twin and the monitor, start the server and feed the monitor (closing what opened on error)."""
        try:
            self._start()
        except BaseException:
            self.close()
            raise
        self.started = True
        return self

    def __enter__(self) -> LiveServe:
        return self if self.started else self.start()

    def __exit__(self, *exc) -> None:
        self.close()

    def wait(self, duration_s: float = 0.0) -> None:
        """Until Ctrl-C (or SIGTERM), the server stops, or ``duration_s`` (0: no limit) passed; then the caller's
        ``with`` closes everything in order (the monitor commits what waits, the twin closes)."""
        deadline = time.monotonic() + duration_s if duration_s > 0 else float("inf")
        signal.signal(signal.SIGTERM, _interrupt)
        try:
            while self.server.thread.is_alive() and time.monotonic() < deadline:
                self.server.thread.join(0.2)
        except KeyboardInterrupt:
            pass

    def close(self) -> None:
        for close in reversed(self._closers):
            close()
        self._closers.clear()

    def _start(self) -> None:
        from bim2rdt.server import TokenEntry, create_app, new_token, token_digest
        from bim2rdt.server.runner import ServerThread, listening_socket

        sock = listening_socket(self.config.host, self.config.port)  # first: a busy port is said before the work
        self._closers.append(sock.close)
        twin = self._open_twin()
        self.clock = demo_clock(twin, self.speed) if self.demo and not (self.mqtt or self.nats) else None
        monitor, identity = self._open_monitor()
        roles = ("viewer", "safety", "admin") if self.all_roles else ("viewer",)
        self.tokens = {role: new_token() for role in roles}
        entries = [TokenEntry(name=f"serve-{role}", role=role, sha256=token_digest(token))
                   for role, token in self.tokens.items()]
        config = self.config.model_copy(update={"tokens": [*self.config.tokens, *entries]})
        self.audit_path = (self.out_dir / "live" / "audit.jsonl" if self.demo
                           else config.resolved_audit_log(self.settings.data_dir))
        clock = {"clock": self.clock} if self.clock is not None else {}
        self.app = create_app(twin, monitor, identity=identity, config=config, audit_log=self.audit_path,
                              record_safety=True, **clock)
        self.server = ServerThread(self.app, config.host, config.port, sock=sock).start()
        self._closers.append(self.server.stop)
        self.url = self.server.url
        self.source = self._feed(monitor)

    def _open_twin(self):
        from bim2rdt.twin import DigitalTwin

        url, ifc = self.twin_url, self.ifc
        if self.demo:
            self.progress(f"the embedded demo in {self.out_dir}")

            def stage(name: str) -> None:
                self.progress(f"no demo in {self.out_dir} yet: running its site day ({name})")

            ifc, database = ensure_site_day(self.out_dir, self.settings, stage)
            url = f"sqlite:///{database}"
        twin = DigitalTwin.open(url, ifc, tolerances=self.settings.twin.tolerance_policy(),
                                min_fitness=self.settings.twin.min_fitness, family_mesh=_family_mesh, create=False)
        self._closers.append(twin.close)
        return twin

    def _open_monitor(self):
        if not (self.demo or self.mqtt or self.nats):
            return None, None
        from bim2rdt.safety import HavError, HavMonitor, IdentityMap, PartitionIdentities

        if self.nats and not self.settings.hav.store_url:
            raise HavError("serve --nats reads the partitions' shared store: set BIM2RDT_HAV__STORE_URL to the URL "
                           "their monitors use")
        folder = fresh_folder(self.out_dir / "live" / "hav") if self.demo and not (self.mqtt or self.nats) \
            else self.settings.data_dir / "hav"
        clock = {"clock": self.clock.now} if self.clock is not None else {}  # its day is the demo's simulated day
        monitor = HavMonitor(folder, self.settings.hav.site_secret, [], self.settings.hav.monitor_config(), **clock)
        self._closers.append(monitor.close)
        identity = PartitionIdentities(folder, role="safety") if self.nats else \
            IdentityMap(folder / "private" / "identity.sqlite", role="safety")
        self._closers.append(identity.close)
        return monitor, identity

    def _feed(self, monitor) -> str:
        """Attach the monitor to its input: a broker, or the demo's simulated wearables on an in-process bus."""
        if monitor is None:
            return "no HAV monitor (give --mqtt HOST:PORT for wearables)"
        site = self.settings.mqtt.site
        if self.nats:
            from bim2rdt.bus.credentials import user_password
            from bim2rdt.bus.nats_bus import probe

            mqtt = self.settings.mqtt
            probe(self.nats, mqtt.username, user_password(mqtt.username, mqtt.username, mqtt.password,
                                                          mqtt.device_secret))
            reader = StoreReader(monitor).start()
            self._closers.append(reader.stop)
            return f"every partition's workers from the shared store of {self.nats} (site {site})"
        if self.mqtt:
            from bim2rdt.bus.credentials import user_password
            from bim2rdt.bus.mqtt import MqttBus

            mqtt = self.settings.mqtt
            password = user_password(mqtt.username, mqtt.username, mqtt.password, mqtt.device_secret)
            bus = MqttBus(*self.mqtt, client_id=f"bim2rdt-hav-monitor-{site}", username=mqtt.username,
                          password=password, session_expiry_s=mqtt.session_expiry_s, manual_ack=True)
            monitor.attach(bus)  # before connecting: the broker may deliver what it queued for us at once
            bus.connect()
            self._closers.append(bus.close)
            ticker = LiveWearables(monitor, bus, [], site).start_ticking()
            self._closers.append(ticker.stop)
            return f"wearables from mqtt://{self.mqtt[0]}:{self.mqtt[1]} (site {site})"
        from bim2rdt.bus import LocalBus
        from bim2rdt.demo.site_day import WORK_ZONE

        bus = LocalBus().connect()
        monitor.attach(bus)
        wearables = LiveWearables(monitor, bus, live_plans(WORK_ZONE), site, self.speed, t0=self.clock.origin_s).start()
        self._closers.append(wearables.stop)
        return f"3 simulated wearables at {self.speed:g}x"


def _interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def _family_mesh(family: str):
    """The simulator's mesh of a family the BIM lacks (None: the twin stands a box in)."""
    import numpy as np

    from bim2rdt.sim.meshes import UnknownFamilyError, mesh_for_family

    try:
        mesh = mesh_for_family(family)
    except UnknownFamilyError:
        return None
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)
