"""`bim2rdt serve` and `bim2rdt token` as a user runs them: a served twin over real HTTP with the printed viewer
token, the demo's live wearables moving the gauges, and one-line errors for bad options."""

from __future__ import annotations

import hashlib
import json
import re
import shutil
import subprocess
import sys
import time

import httpx
import pytest

from server_helpers import auth, family_mesh, record_day

URL_LINE = re.compile(r"dashboard: (http://127\.0\.0\.1:\d+)/#token=(\S+)")


def _cli(*args, timeout=120):
    return subprocess.run([sys.executable, "-m", "bim2rdt", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout)


@pytest.fixture
def recorded_site(tmp_path, site_ifc, site_model):
    """A folder holding site.ifc and a recorded twin.db, as the demo leaves them."""
    from bim2rdt.twin import DigitalTwin

    shutil.copy(site_ifc, tmp_path / "site.ifc")
    with DigitalTwin.open(f"sqlite:///{tmp_path / 'twin.db'}", site_model, family_mesh=family_mesh) as twin:
        ids = record_day(twin, site_model)
    return tmp_path, ids


class Served:
    """`bim2rdt serve ...` in a subprocess until it prints its URL."""

    def __init__(self, *args, env=None):
        self.process = subprocess.Popen([sys.executable, "-m", "bim2rdt", "serve", *map(str, args)],
                                        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
        self.lines = []
        for line in self.process.stdout:
            self.lines.append(line)
            if match := URL_LINE.search(line):
                self.url, self.token = match.groups()
                return
        raise AssertionError("serve printed no URL:\n" + "".join(self.lines))

    def stop(self) -> str:
        """SIGTERM (the server closes in order); the rest of its output (read through the same buffered pipe:
        communicate() would read past what the line reader already buffered)."""
        self.process.terminate()
        rest = self.process.stdout.read()
        self.process.wait(60)
        return "".join(self.lines) + rest


def test_serve_a_given_twin_prints_its_url_and_a_working_viewer_token(recorded_site):
    folder, ids = recorded_site
    served = Served("--twin", f"sqlite:///{folder / 'twin.db'}", "--ifc", folder / "site.ifc", "--port", 0,
                    "--duration", 60)
    try:
        assert served.url.startswith("http://127.0.0.1:")  # bound to this machine by default
        elements = httpx.get(f"{served.url}/api/elements", headers=auth(served.token), timeout=30)
        assert elements.status_code == 200
        assert {e["global_id"]: e["status"] for e in elements.json()}[ids["moved"]] == "deviating"
        assert httpx.get(f"{served.url}/api/elements", timeout=30).status_code == 401
        workers = httpx.get(f"{served.url}/api/workers", headers=auth(served.token), timeout=30)
        assert workers.status_code == 503  # no --mqtt: no monitor
    finally:
        output = served.stop()
    assert f"viewer token: {served.token}" in output


def test_serve_the_demo_moves_the_gauges_with_simulated_wearables(recorded_site):
    folder, _ = recorded_site
    served = Served("--out", folder, "--port", 0, "--speed", 50, "--all-roles", "--duration", 120)
    try:
        headers = auth(served.token)
        deadline, seen = time.monotonic() + 60, []
        while time.monotonic() < deadline:
            workers = httpx.get(f"{served.url}/api/workers", headers=headers, timeout=30).json()
            seen.append(max((w["a8"] or 0.0 for w in workers), default=0.0))
            if len(workers) == 3 and seen[-1] > 0 and len(seen) > 2 and seen[-1] > seen[-3]:
                break
            time.sleep(1.0)
        assert len(workers) == 3 and seen[-1] > 0 and seen[-1] > seen[-3], seen
        assert all(w["subject"].startswith("w-") for w in workers)
        clock = httpx.get(f"{served.url}/api/clock", headers=headers, timeout=30).json()
        events = httpx.get(f"{served.url}/api/events", headers=headers, timeout=30).json()
        assert clock["simulated"] and clock["speed"] == 50.0
        assert events and all(e["time"] <= clock["now"] + 1.0 for e in events)  # one clock: none in its future
    finally:
        output = served.stop()
    assert "safety token:" in output and "admin token:" in output
    assert (folder / "live" / "hav" / "hav.sqlite").is_file()


def test_token_prints_a_token_and_the_entry_that_stores_only_its_digest():
    result = _cli("token", "--role", "safety", "--name", "alice")
    assert result.returncode == 0, result.stderr
    token = re.search(r"token: (\S+)", result.stdout).group(1)
    entry = json.loads(result.stdout.split("settings entry: ", 1)[1])
    assert entry == {"name": "alice", "role": "safety", "sha256": hashlib.sha256(token.encode()).hexdigest()}


@pytest.mark.parametrize("args, words", [
    (("token", "--role", "boss", "--name", "x"), "role must be one of"),
    (("serve", "--twin", "sqlite:////nonexistent/twin.db"), "--twin needs --ifc"),
    (("serve", "--twin", "sqlite:///x.db", "--ifc", "x.ifc", "--mqtt", "localhost"), "wants HOST:PORT"),
])
def test_bad_options_are_one_line_usage_errors(args, words):
    result = _cli(*args)
    assert result.returncode == 2 and words in result.stderr + result.stdout


@pytest.mark.parametrize("name", ["a/b", "", "x" * 100])
def test_a_token_holder_name_that_cannot_be_stored_is_a_one_line_error(name):
    result = _cli("token", "--name", name)
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2 and len(lines) == 1 and "--name" in lines[0], result.stderr
    assert "token:" not in result.stdout


def test_serve_on_a_busy_port_or_a_bad_host_is_a_one_line_error_at_once(recorded_site):
    import socket

    folder, _ = recorded_site
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        for host, port, words in (("127.0.0.1", busy.getsockname()[1], "address already in use"),
                                  ("no-such-host.invalid", 0, "cannot listen on no-such-host.invalid"),
                                  ("300.1.1.1", 0, "cannot listen on 300.1.1.1")):
            started = time.monotonic()
            result = _cli("serve", "--twin", f"sqlite:///{folder / 'twin.db'}", "--ifc", folder / "site.ifc",
                          "--host", host, "--port", port, "--duration", 1, timeout=60)
            lines = result.stderr.strip().splitlines()
            assert result.returncode == 1 and len(lines) == 1, result.stderr
            assert words in lines[0].lower() and time.monotonic() - started < 20, lines


def test_a_twin_url_that_holds_no_twin_is_a_one_line_error(tmp_path, site_ifc):
    result = _cli("serve", "--twin", f"sqlite:///{tmp_path / 'none.db'}", "--ifc", site_ifc, "--port", 0)
    assert result.returncode == 1
    assert result.stderr.strip().startswith("error: no twin at") and len(result.stderr.strip().splitlines()) == 1


def _env_without_secrets(tmp_path, **extra):
    import os

    env = {k: v for k, v in os.environ.items() if k not in ("BIM2RDT_HAV__SITE_SECRET", "BIM2RDT_MQTT__PASSWORD")}
    return {**env, "BIM2RDT_DATA_DIR": str(tmp_path / "var"), **extra}


@pytest.mark.parametrize("extra, variable", [({}, "BIM2RDT_HAV__SITE_SECRET"),
                                             ({"BIM2RDT_HAV__SITE_SECRET": "s3cret-of-the-site"},
                                              "BIM2RDT_MQTT__PASSWORD")])
def test_serve_with_a_broker_refuses_the_shipped_secrets_in_one_line(recorded_site, tmp_path, extra, variable):
    folder, _ = recorded_site
    result = subprocess.run([sys.executable, "-m", "bim2rdt", "serve", "--twin", f"sqlite:///{folder / 'twin.db'}",
                             "--ifc", folder / "site.ifc", "--port", "0", "--mqtt", "127.0.0.1:1", "--duration", "1"],
                            capture_output=True, text=True, timeout=120, env=_env_without_secrets(tmp_path, **extra))
    assert result.returncode == 1, result.stdout + result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and variable in lines[0] and "--dev" in lines[0], result.stderr
    assert "dashboard:" not in result.stdout


def test_serve_with_a_broker_and_dev_takes_the_shipped_secrets_under_a_banner(recorded_site, tmp_path):
    folder, _ = recorded_site
    result = subprocess.run([sys.executable, "-m", "bim2rdt", "serve", "--twin", f"sqlite:///{folder / 'twin.db'}",
                             "--ifc", folder / "site.ifc", "--port", "0", "--mqtt", "127.0.0.1:1", "--dev",
                             "--duration", "1"], capture_output=True, text=True, timeout=120,
                            env=_env_without_secrets(tmp_path))
    assert "DEV" in result.stdout and "BIM2RDT_HAV__SITE_SECRET" in result.stdout, result.stdout
    assert "cannot reach MQTT broker 127.0.0.1:1" in result.stderr  # it went on, to the broker


@pytest.mark.mqtt
def test_serve_takes_real_wearables_from_a_broker(recorded_site, tmp_path):
    import os
    from pathlib import Path

    from bim2rdt.bus.broker import MOSQUITTO, MosquittoBroker
    from bim2rdt.sim.wearables import WorkerPlan, run_over_mqtt

    if not Path(MOSQUITTO).exists():
        pytest.fail("Debian's mosquitto is required (.ci/run installs it)")
    folder, _ = recorded_site
    users = {"monitor": "monitor-pw", "w7": "w7-pw"}
    with MosquittoBroker(users, folder=tmp_path / "mosquitto") as broker:
        env = {**os.environ, "BIM2RDT_MQTT__PASSWORD": "monitor-pw", "BIM2RDT_DATA_DIR": str(tmp_path / "var"),
               "BIM2RDT_HAV__SITE_SECRET": "a-site-secret-of-this-test"}
        served = Served("--twin", f"sqlite:///{folder / 'twin.db'}", "--ifc", folder / "site.ifc", "--port", 0,
                        "--mqtt", f"127.0.0.1:{broker.port}", "--duration", 120, env=env)
        try:
            plan = WorkerPlan("w7", "worker-777", "Work zone A", (("idle", 2.0), ("grinder", 20.0), ("idle", 3.0)))
            run_over_mqtt([plan], "demo", 2500.0, "127.0.0.1", broker.port, users.__getitem__)
            deadline, workers = time.monotonic() + 30, []
            while time.monotonic() < deadline and not (workers and workers[0]["a8"]):
                time.sleep(0.5)
                workers = httpx.get(f"{served.url}/api/workers", headers=auth(served.token), timeout=30).json()
            events = httpx.get(f"{served.url}/api/events", headers=auth(served.token), timeout=30).json()
        finally:
            served.stop()
    assert len(workers) == 1 and workers[0]["a8"] > 0 and workers[0]["devices"][0]["tool"] == "grinder"
    assert {"hav.activity_started", "hav.activity_ended"} <= {e["kind"] for e in events}
    assert (tmp_path / "var" / "hav" / "hav.sqlite").is_file()
