"""A private nats-server (Debian's ``nats-server`` 2.9) with JetStream and its MQTT listener, for tests, benchmarks
and local runs; and the configuration it and production use (``docs/deploy/`` ships rendered examples).

Security, as with Mosquitto (:mod:`bim2rdt.bus.broker`):
- one user per device; after the account's partition mapping (:mod:`bim2rdt.bus.partitions`) it may publish only
  its own accel and status subject of the one site, in its one partition, and subscribe to nothing. nats-server
  2.9 checks an MQTT client's publish permission on the MAPPED subject, so the permission names the partition;
  a publish outside it is dropped by the server ("Publish Violation") and reaches no stream;
- monitor users may read the HAV stream through JetStream pull consumers (create the stream and their consumers,
  fetch, acknowledge) and publish the site's safety events; they cannot publish as a wearable;
- no anonymous clients; passwords live in a private folder (mode 0600) removed when the server stops.
JetStream keeps files in ``store_dir``, bounded by ``max_file_store`` (server) and the stream's age and size limits.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING
from pathlib import Path

from bim2rdt.bus.broker import BrokerError, free_port, port_in_use
from bim2rdt.bus.partitions import STREAM, check_subject_level, device_subjects, partition_mapping

if TYPE_CHECKING:
    from bim2rdt.bus.nats_bus import StreamLimits

NATS_SERVER = "/usr/sbin/nats-server"


@dataclass(frozen=True)
class NatsLayout:
    """What one nats-server of a site serves: its users and how the wearable subjects are partitioned."""

    site: str
    devices: dict[str, str]
    """device id -> password"""
    monitors: dict[str, str]
    """monitor user -> password"""
    partitions: int = 1
    port: int = 4222
    mqtt_port: int = 1883
    host: str = "127.0.0.1"
    store_dir: str = "/var/lib/nats"
    max_file_store: int = 10 * 2**30
    server_name: str = "bim2rdt-1"
    cluster: dict = field(default_factory=dict)
    """For a cluster node: {"name": ..., "port": ..., "routes": ["nats://host:port", ...]} (else {})."""


def monitor_permissions(site: str) -> dict:
    """What a monitor user may do: run pull consumers on the HAV stream, publish the site's safety events."""
    return {"publish": {"allow": ["$JS.API.INFO", f"$JS.API.STREAM.INFO.{STREAM}", f"$JS.API.STREAM.CREATE.{STREAM}",
                                  f"$JS.API.STREAM.UPDATE.{STREAM}", f"$JS.API.CONSUMER.*.{STREAM}",
                                  f"$JS.API.CONSUMER.*.{STREAM}.>", f"$JS.API.CONSUMER.*.*.{STREAM}.>",
                                  f"$JS.ACK.{STREAM}.>", f"site.{site}.safety.>"]},
            "subscribe": {"allow": ["_INBOX.>"]}}


def device_permissions(site: str, device: str, partitions: int) -> dict:
    return {"publish": {"allow": device_subjects(site, device, partitions)}, "subscribe": {"deny": [">"]}}


def password_variable(user: str) -> str:
    """The environment variable a shipped config reads ``user``'s password from (nats-server resolves ``$NAME``)."""
    return "BIM2RDT_NATS_PASSWORD_" + "".join(c if c.isalnum() else "_" for c in user).upper()


def render_nats_config(layout: NatsLayout, passwords_from_env: bool = False) -> str:
    """The nats-server configuration of ``layout`` (nats-server 2.9 syntax; JSON values are valid there). With
    ``passwords_from_env`` no secret is written: each password is ``$BIM2RDT_NATS_PASSWORD_<USER>``, read from the
    server's environment (:func:`password_variable`); the given passwords are ignored."""
    check_subject_level(layout.site, "site")
    users = [{"user": name, "password": password, "permissions": monitor_permissions(layout.site)}
             for name, password in layout.monitors.items()]
    users += [{"user": device, "password": password,
               "permissions": device_permissions(layout.site, device, layout.partitions)}
              for device, password in layout.devices.items()]
    if passwords_from_env:
        users = [{**user, "password": f"${password_variable(user['user'])}"} for user in users]
    source, destination = partition_mapping(layout.partitions)
    lines = [
        "# bim2rdt: nats-server 2.9 for the HAV monitor's scaled path (rendered by bim2rdt.bus.nats_broker).",
        f"server_name: {json.dumps(layout.server_name)}",
        f"listen: {json.dumps(f'{layout.host}:{layout.port}')}",
        "max_payload: 1MB",
        "jetstream {",
        f"  store_dir: {json.dumps(layout.store_dir)}",
        f"  max_file_store: {layout.max_file_store}",
        "  max_memory_store: 67108864",
        "}",
        "# Wearables publish MQTT 3.1.1 QoS 1 here; site/S/wearable/D/accel becomes the subject site.S.wearable.D.accel",
        "mqtt {",
        f"  listen: {json.dumps(f'{layout.host}:{layout.mqtt_port}')}",
        "}",
        "# Every wearable subject gets its partition: hav.<k>.site.S.wearable.D.<leaf>, k = FNV-1a(S D) mod N.",
        f"mappings = {{ {json.dumps(source)}: {json.dumps(destination)} }}",
    ]
    if layout.cluster:
        routes = ", ".join(json.dumps(route) for route in layout.cluster.get("routes", []))
        lines += ["cluster {", f"  name: {json.dumps(layout.cluster['name'])}",
                  f"  listen: {json.dumps(layout.cluster.get('listen', '0.0.0.0:6222'))}",
                  f"  routes: [{routes}]", "}"]
    lines += ["authorization {", "  users = ["]
    lines += [f"    {_user_line(user, passwords_from_env)}," for user in users]
    lines += ["  ]", "}"]
    return "\n".join(lines) + "\n"


def _user_line(user: dict, password_is_variable: bool) -> str:
    text = json.dumps(user)
    if password_is_variable:  # a variable reference is unquoted in nats-server's config language
        text = text.replace(json.dumps(user["password"]), user["password"], 1)
    return text


class NatsServer:
    """A real nats-server on 127.0.0.1 (``port`` for NATS, ``mqtt_port`` for MQTT) serving ``layout``'s users;
    a context manager. Its folder (config with passwords, JetStream files) is its own temporary one, removed
    when it stops; in a given ``folder`` only the config (it holds the passwords) is removed."""

    def __init__(self, site: str, devices: dict[str, str], monitors: dict[str, str], partitions: int = 1,
                 port: int | None = None, mqtt_port: int | None = None, folder: Path | None = None,
                 max_file_store: int = 10 * 2**30, limits: StreamLimits | None = None):
        if not Path(NATS_SERVER).exists():
            raise BrokerError(f"{NATS_SERVER} not found: install Debian's nats-server package")
        self._own_folder = folder is None
        self.folder = Path(folder or tempfile.mkdtemp(prefix="bim2rdt-nats-"))
        self.port, self.mqtt_port = port or free_port(), mqtt_port or free_port()
        self.layout = NatsLayout(site, dict(devices), dict(monitors), partitions, self.port, self.mqtt_port,
                                 store_dir=str(self.folder / "jetstream"), max_file_store=max_file_store,
                                 server_name=f"bim2rdt-{self.port}")
        self.limits = limits
        self._process: subprocess.Popen | None = None

    @property
    def url(self) -> str:
        return f"nats://127.0.0.1:{self.port}"

    @property
    def config_path(self) -> Path:
        return self.folder / "nats-server.conf"

    @property
    def log_path(self) -> Path:
        return self.folder / "nats-server.log"

    def start(self) -> NatsServer:
        for port in (self.port, self.mqtt_port):
            if port_in_use(port):
                self._clean()
                raise BrokerError(f"port {port} on 127.0.0.1 is already in use: pick another with --port/--mqtt-port")
        self.folder.mkdir(parents=True, exist_ok=True)
        os.chmod(self.folder, 0o700)
        self.config_path.write_text(render_nats_config(self.layout))
        self.config_path.chmod(0o600)
        self._log = self.log_path.open("ab")
        self._process = subprocess.Popen([NATS_SERVER, "-c", str(self.config_path)], stdout=self._log,
                                         stderr=subprocess.STDOUT)
        self._wait_listening()
        self._create_stream()
        return self

    def _create_stream(self) -> None:
        """The HAV stream exists before any wearable publishes (a message with no stream is not kept)."""
        from bim2rdt.bus.nats_bus import NatsBus, StreamLimits

        user, password = next(iter(self.layout.monitors.items()))
        try:
            NatsBus(self.url, user, password, self.layout.site, limits=self.limits or StreamLimits()).connect().close()
        except Exception:
            self.stop()
            raise

    @property
    def pid(self) -> int | None:
        return self._process.pid if self._process is not None else None

    @property
    def running(self) -> bool:
        return self._process is not None and self._process.poll() is None

    def check(self) -> None:
        """BrokerError if nats-server has exited (with the end of its log)."""
        if self._process is not None and self._process.poll() is not None:
            raise BrokerError(f"nats-server on port {self.port} exited: {self.log_tail()}")

    def log_tail(self, chars: int = 300) -> str:
        try:
            return self.log_path.read_text(errors="replace").strip()[-chars:]
        except OSError:
            return ""

    def violations(self) -> list[str]:
        """The server's 'Publish Violation' log lines so far (a device refused a subject)."""
        try:
            return [line for line in self.log_path.read_text(errors="replace").splitlines()
                    if "Publish Violation" in line]
        except OSError:
            return []

    def stop(self) -> None:
        if self._process is not None and self._process.poll() is None:
            self._process.terminate()
            try:
                self._process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self._process.kill()
                self._process.wait()
        self._process = None
        if getattr(self, "_log", None) is not None:
            self._log.close()
        self._clean()

    def _clean(self) -> None:
        if self._own_folder:
            shutil.rmtree(self.folder, ignore_errors=True)
        else:
            self.config_path.unlink(missing_ok=True)

    def __enter__(self) -> NatsServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _wait_listening(self, timeout_s: float = 15.0) -> None:
        """Until the NATS and MQTT ports both accept connections (the MQTT one opens after JetStream is up)."""
        import socket

        deadline = time.monotonic() + timeout_s
        waiting = [self.port, self.mqtt_port]
        while waiting and time.monotonic() < deadline:
            if self._process.poll() is not None:
                message = f"nats-server exited: {self.log_tail()}"
                self.stop()
                raise BrokerError(message)
            try:
                socket.create_connection(("127.0.0.1", waiting[0]), timeout=0.2).close()
                waiting.pop(0)
            except OSError:
                time.sleep(0.05)
        if waiting:
            self.stop()
            raise BrokerError(f"nats-server did not open 127.0.0.1:{waiting[0]} within {timeout_s} s")
