"""`bim2rdt hav broker` and MosquittoBroker: no secrets left behind, a port in use fails loudly."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time

from pathlib import Path

import pytest

from bim2rdt.bus.broker import BrokerError, MosquittoBroker, free_port, render_acl

ENV = {"BIM2RDT_MQTT__DEVICE_SECRET": "test-devices", "BIM2RDT_MQTT__PASSWORD": "test-monitor",
       "BIM2RDT_HAV__SITE_SECRET": "test-site"}


def run_cli(*args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "bim2rdt", *args], capture_output=True, text=True, timeout=120,
                          env={**os.environ, **(env or {})})


def test_a_broker_removes_its_temporary_folder_password_file_included():
    with MosquittoBroker({"monitor": "pw", "w1": "pw1"}, site="s") as broker:
        folder = broker.folder
        assert (folder / "passwd").exists()
    assert not folder.exists()


def test_in_a_given_folder_the_password_file_is_removed(tmp_path):
    with MosquittoBroker({"monitor": "pw"}, folder=tmp_path, site="s"):
        assert (tmp_path / "passwd").exists()
    assert not (tmp_path / "passwd").exists() and (tmp_path / "acl.conf").exists()


def test_a_port_in_use_is_a_broker_error_and_leaves_nothing_behind():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        broker = MosquittoBroker({"monitor": "pw"}, port=port, site="s")
        with pytest.raises(BrokerError, match=f"port {port} .* in use"):
            broker.start()
        assert not broker.folder.exists()


def test_hav_broker_on_a_port_in_use_exits_1_in_one_line():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        result = run_cli("hav", "broker", "--port", str(taken.getsockname()[1]), "--duration", "5", env=ENV)
    assert result.returncode == 1 and "already in use" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and "mosquitto on" not in result.stdout


def test_the_acl_is_pinned_to_the_site_and_names_the_monitor():
    acl = render_acl("north", ("hav-mon",))
    assert "pattern write site/north/wearable/%u/accel" in acl and "site/+/" not in acl
    assert "user hav-mon\ntopic read site/north/wearable/#" in acl
    with pytest.raises(Exception, match="site"):
        render_acl("a/#", ("m",))


@pytest.mark.parametrize("args, variable", [
    (["hav", "listen", "--mqtt", "127.0.0.1:1", "--duration", "1"], "BIM2RDT_HAV__SITE_SECRET"),
    (["hav", "broker", "--duration", "1"], "BIM2RDT_MQTT__DEVICE_SECRET"),
    (["sim", "wearables", "--mqtt", "127.0.0.1:1", "--minutes", "1"], "BIM2RDT_MQTT__DEVICE_SECRET"),
    (["sim", "wearables", "--minutes", "1"], "BIM2RDT_HAV__SITE_SECRET")])
def test_the_shipped_default_secrets_refuse_to_start_outside_dev(args, variable, tmp_path):
    env = {"BIM2RDT_DATA_DIR": str(tmp_path)}
    result = run_cli(*args, env=env)
    assert result.returncode == 1 and variable in result.stderr and "--dev" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_the_monitor_needs_its_own_password_outside_dev(tmp_path):
    result = run_cli("hav", "listen", "--mqtt", "127.0.0.1:1", env={"BIM2RDT_HAV__SITE_SECRET": "s3cret-of-this-site",
                                                                    "BIM2RDT_DATA_DIR": str(tmp_path)})
    assert result.returncode == 1 and "BIM2RDT_MQTT__PASSWORD" in result.stderr


def test_dev_runs_a_broker_with_the_defaults():
    port = free_port()
    result = run_cli("hav", "broker", "--dev", "--port", str(port), "--duration", "1")
    assert result.returncode == 0, result.stderr
    assert f"mosquitto on 127.0.0.1:{port}" in result.stdout


@pytest.mark.parametrize("signum", [signal.SIGHUP, signal.SIGTERM, signal.SIGINT])
def test_hav_broker_stopped_by_a_signal_leaves_no_mosquitto_and_no_folder(tmp_path, signum):
    """SIGHUP is what a closed terminal sends: it must stop mosquitto and remove the password file like Ctrl-C."""
    port, mosquitto = free_port(), None
    command = subprocess.Popen([sys.executable, "-m", "bim2rdt", "hav", "broker", "--port", str(port)],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               env={**os.environ, **ENV, "TMPDIR": str(tmp_path)})
    try:
        assert "mosquitto on" in command.stdout.readline()
        folders = list(tmp_path.glob("bim2rdt-mosquitto-*"))
        assert len(folders) == 1 and (folders[0] / "passwd").exists()
        mosquitto = int(Path(f"/proc/{command.pid}/task/{command.pid}/children").read_text().split()[0])
        command.send_signal(signum)
        command.wait(timeout=30)
        deadline = time.monotonic() + 5
        while _alive(mosquitto) and time.monotonic() < deadline:
            time.sleep(0.05)
        orphaned = _alive(mosquitto)
    finally:
        if command.poll() is None:
            command.kill()
        if _alive(mosquitto):
            os.kill(mosquitto, signal.SIGTERM)  # the test's own orphan, never left serving the port
    assert not orphaned, "mosquitto outlived the command"
    assert command.returncode == 0, command.stderr.read()
    assert not folders[0].exists()
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", port))  # the port is free again


def _alive(pid: int | None) -> bool:
    """Whether the process runs (a zombie waiting for its reaper counts as gone)."""
    try:
        return pid is not None and Path(f"/proc/{pid}/stat").read_text().split(") ")[1][0] != "Z"
    except (FileNotFoundError, IndexError):
        return False
