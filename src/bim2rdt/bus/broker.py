"""Run the project's Mosquitto configuration on a private loopback port (tests, benchmarks, local demos).

The shipped ``mosquitto.conf`` and ``acl.conf`` are used unchanged except for the port and file locations.
Passwords are written with Debian's ``mosquitto_passwd -b`` (see :mod:`bim2rdt.bus.credentials` for who gets
which).
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import tempfile
import time
from importlib import resources
from pathlib import Path

from bim2rdt.bus.topics import check_level
from bim2rdt.errors import Bim2RdtError

MOSQUITTO = "/usr/sbin/mosquitto"
_REWRITTEN = ("listener", "password_file", "acl_file", "persistence_location")


class BrokerError(Bim2RdtError):
    """The Mosquitto broker could not be started (binary missing, bad config, port not opening)."""


def shipped_config(name: str) -> str:
    """Text of a shipped Mosquitto file: 'mosquitto.conf' or 'acl.conf'."""
    return resources.files("bim2rdt.bus").joinpath("mosquitto", name).read_text()


def free_port() -> int:
    """A free TCP port on 127.0.0.1 (never 1883: a system broker may own it)."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def render_acl(site: str, monitors: tuple[str, ...] = ("monitor",)) -> str:
    """The shipped acl.conf for ``site``, its monitor block once per user in ``monitors``."""
    check_level(site, "site")
    for user in monitors:
        check_level(user, "monitor user")
    lines, out, block = shipped_config("acl.conf").splitlines(), [], None
    for line in lines + [""]:
        if line.startswith("user @MONITOR@"):
            block = [line]
        elif block is not None and line.strip():
            block.append(line)
        elif block is not None:
            for user in monitors:
                out += [entry.replace("@MONITOR@", user) for entry in block] + [""]
            block = None
        else:
            out.append(line)
    return "\n".join(line if line.startswith("#") else line.replace("@SITE@", site) for line in out).rstrip() + "\n"


def port_in_use(port: int) -> bool:
    """Whether something already listens on (or holds) 127.0.0.1:``port``."""
    with socket.socket() as sock:
        try:
            sock.bind(("127.0.0.1", port))
        except OSError:
            return True
    return False


def render_config(port: int, folder: Path) -> str:
    """The shipped mosquitto.conf with the listener on ``port`` and files under ``folder``."""
    values = {"listener": f"{port} 127.0.0.1", "password_file": str(folder / "passwd"),
              "acl_file": str(folder / "acl.conf"), "persistence_location": f"{folder}/"}
    lines = []
    for line in shipped_config("mosquitto.conf").splitlines():
        key = line.split(" ", 1)[0]
        lines.append(f"{key} {values[key]}" if key in _REWRITTEN else line)
    if os.geteuid() == 0:  # as root mosquitto would drop to user 'mosquitto', who cannot read a private folder
        lines.append("user root")
    return "\n".join(lines) + "\n"


class MosquittoBroker:
    """A real Mosquitto on 127.0.0.1:``port`` with one password per user in ``users`` and the ACL of ``site``
    (``monitors`` name the monitor users); a context manager. Its own temporary folder (password file included)
    is removed when it stops; in a given ``folder`` the password file is."""

    def __init__(self, users: dict[str, str], port: int | None = None, folder: Path | None = None,
                 site: str = "demo", monitors: tuple[str, ...] = ("monitor",)):
        if not Path(MOSQUITTO).exists():
            raise BrokerError(f"{MOSQUITTO} not found: install Debian's mosquitto package")
        self.users, self.port, self.site, self.monitors = users, port or free_port(), site, tuple(monitors)
        self._own_folder = folder is None
        self.folder = Path(folder or tempfile.mkdtemp(prefix="bim2rdt-mosquitto-"))
        self._process: subprocess.Popen | None = None

    @property
    def running(self) -> bool:
        return self._process is not None and self._process.poll() is None

    def check(self) -> None:
        """BrokerError if the mosquitto process has exited (with what it said)."""
        if self._process is not None and self._process.poll() is not None:
            raise BrokerError(f"mosquitto on port {self.port} exited: {self._stderr()}")

    def start(self) -> MosquittoBroker:
        if port_in_use(self.port):
            self._clean()
            raise BrokerError(f"port {self.port} on 127.0.0.1 is already in use: pick another with --port")
        self.folder.mkdir(parents=True, exist_ok=True)
        self._write_passwords()
        (self.folder / "acl.conf").write_text(render_acl(self.site, self.monitors))
        (self.folder / "mosquitto.conf").write_text(render_config(self.port, self.folder))
        self._process = subprocess.Popen([MOSQUITTO, "-c", str(self.folder / "mosquitto.conf")],
                                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        self._wait_listening()
        return self

    def stop(self) -> None:
        if self._process is not None and self._process.poll() is None:
            self._process.terminate()
            try:
                self._process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self._process.kill()
                self._process.wait()
        self._process = None
        self._clean()

    def _clean(self) -> None:
        """Remove what holds secrets: our own folder entirely, else the password file."""
        if self._own_folder:
            shutil.rmtree(self.folder, ignore_errors=True)
        else:
            (self.folder / "passwd").unlink(missing_ok=True)

    def _stderr(self) -> str:
        return self._process.stderr.read().decode(errors="replace").strip()[:300] if self._process.stderr else ""

    def __enter__(self) -> MosquittoBroker:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _write_passwords(self) -> None:
        tool = shutil.which("mosquitto_passwd") or "/usr/bin/mosquitto_passwd"
        path = self.folder / "passwd"
        path.write_text("")
        for user, password in self.users.items():
            subprocess.run([tool, "-b", str(path), user, password], check=True, capture_output=True)
        path.chmod(0o600)

    def _wait_listening(self, timeout_s: float = 10.0) -> None:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self._process.poll() is not None:
                message = f"mosquitto exited: {self._stderr()}"
                self.stop()
                raise BrokerError(message)
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=0.2).close()
                return
            except OSError:
                time.sleep(0.05)
        self.stop()
        raise BrokerError(f"mosquitto did not open 127.0.0.1:{self.port} within {timeout_s} s")
