"""The HAV command line: analyze a recording, simulate wearables into the twin, the benchmark, a live run
through a real Mosquitto (broker, listener and simulated devices as separate processes)."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from contextlib import contextmanager
from pathlib import Path

import pytest

from bim2rdt.bim import load_ifc
from bim2rdt.bus.broker import free_port
from bim2rdt.safety import HavMonitor, MonitorConfig, daily_exposure
from bim2rdt.safety.recording import write_accel_csv
from bim2rdt.sim.site import build_site_ifc
from bim2rdt.sim.vibration import session_signal


def run_cli(*args: str, env: dict | None = None, timeout: float = 180) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "bim2rdt", *args], capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, **(env or {})})


@pytest.fixture
def cli_env(tmp_path):
    return {"BIM2RDT_DATA_DIR": str(tmp_path / "var"), "BIM2RDT_MQTT__DEVICE_SECRET": "test-devices",
            "BIM2RDT_HAV__SITE_SECRET": "test-site", "BIM2RDT_MQTT__PASSWORD": "test-monitor",
            "BIM2RDT_MQTT__SITE": "t", "COLUMNS": "160"}


def test_analyze_reports_the_exposure_of_a_recording_and_plots_the_day(tmp_path):
    fs = 2000.0
    signal = session_signal([("idle", 3), ("grinder", 40), ("idle", 5)], fs, a_hv={"grinder": 6.0})
    path = write_accel_csv(tmp_path / "day.csv", signal, fs)
    result = run_cli("hav", "analyze", str(path), "--out", str(tmp_path / "out"), "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["fs"] == pytest.approx(fs)
    assert len(report["activities"]) == 1 and report["activities"][0]["a_hv"] == pytest.approx(6.0, rel=0.05)
    assert report["a8"] == pytest.approx(daily_exposure(6.0, 40.0), rel=0.05)
    assert report["band_limited"] is True  # 2 kHz covers up to 794 Hz, not 1000 Hz
    assert report["rejected_s"] == 0.0 and report["rejected_kinds"] == []
    assert (tmp_path / "out" / "day_a8.png").stat().st_size > 10_000


@pytest.mark.parametrize("content, message", [("a,b\n1,2\n", "header needs a time column"),
                                              ("t,ax,ay,az\n0,1,2,x\n", "not numeric"),
                                              ("t,ax,ay,az\n", "only 0 samples"), ("", "header needs")])
def test_analyze_refuses_a_bad_file_in_one_line(tmp_path, content, message):
    path = tmp_path / "bad.csv"
    path.write_text(content)
    result = run_cli("hav", "analyze", str(path))
    assert result.returncode == 1
    assert message in result.stderr and len(result.stderr.strip().splitlines()) == 1


def test_an_unwritable_csv_path_is_a_one_line_error(tmp_path, cli_env):
    (tmp_path / "taken").write_text("a file where the folder should be")
    result = run_cli("sim", "wearables", "--workers", "1", "--minutes", "1", "--fs", "1000", "--csv",
                     str(tmp_path / "taken" / "w1.csv"), env=cli_env)
    assert result.returncode == 1 and result.stderr.startswith("error: cannot write")
    assert len(result.stderr.strip().splitlines()) == 1


def test_a_malformed_broker_address_is_a_one_line_error():
    result = run_cli("hav", "listen", "--mqtt", "no-port-here")
    assert result.returncode == 1 and "HOST:PORT" in result.stderr


def test_simulated_wearables_in_process_write_the_twin(tmp_path, cli_env):
    site = build_site_ifc(tmp_path / "site.ifc")
    result = run_cli("sim", "wearables", "--workers", "2", "--minutes", "3", "--fs", "1000", "--ifc", str(site),
                     "--out", str(tmp_path / "twin.ifc"), env=cli_env)
    assert result.returncode == 0, result.stderr
    assert "activity_started" in result.stdout and "Daily exposure" in result.stdout
    twin = load_ifc(tmp_path / "twin.ifc", geometry=False)
    zone = next(z.global_id for z in twin.zones if z.name == "Work Zone A - Drilling")
    assert sum(e.name.startswith("HAV activity started") for e in twin.events) == 6  # 2 workers x 3 tools
    assert all(zone in e.related for e in twin.events)


def test_bench_hav_reports_throughput_against_the_floor_and_latency(cli_env):
    result = run_cli("bench", "hav", "--streams", "40", "--seconds", "2", "--messages", "30", "--store-minutes", "2",
                     "--json", env=cli_env)
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["throughput"]["streams"] == 40 and report["throughput"]["ratio_to_floor"] > 0
    assert report["latency"]["messages"] == 30 and report["latency"]["p99_ms"] >= report["latency"]["p50_ms"] > 0
    store = report["store"]["modes"]
    assert store["per_message"]["batches_per_commit"] == pytest.approx(1.0, abs=0.05)  # status messages commit too
    assert store["group_commit"]["batches_per_commit"] > 10 and store["group_commit"]["commits_per_s"] > 0
    assert all(mode["reads_per_batch_last_quarter"] <= 2.0 for mode in store.values())
    assert set(report["targets"]) == {"streams_ge_2000", "within_1_5x_floor", "store_reads_per_batch_le_2"}



@pytest.mark.parametrize("seconds", [6, 9])
def test_bench_hav_gives_decoded_batches_and_the_floor_c_ordered_rows_whatever_the_length(seconds):
    """The simulator lays a signal out column-major up to 8 s and row-major from 9 s; the bench's batches are laid
    out as decoded payloads whatever the length, and the floor's stacked rows are C-ordered, so sosfilt's copy is
    a plain copy (it gathered a column-major input at 0.34 s a round instead of 0.20 s)."""
    import numpy as np

    from bim2rdt.bench.hav import TOOLS, _as_decoded, _rows
    from bim2rdt.bus import AccelBatch
    from bim2rdt.bus.payloads import decode_accel, encode_accel
    from bim2rdt.sim.vibration import WEARABLE_RANGE, tool_vibration

    raw = tool_vibration(TOOLS[0], seconds + 1, 5000.0, seed=0)
    samples = _as_decoded(raw)
    batches = [AccelBatch(f"d{i}", 0, 1.7e9, 5000.0, samples[i * 500:(i + 1) * 500], WEARABLE_RANGE) for i in range(3)]
    decoded = decode_accel(encode_accel(batches[0], dtype="float32")).xyz
    assert np.array_equal(samples, raw) and samples.dtype == decoded.dtype == np.float32
    assert all(b.xyz.flags.c_contiguous for b in batches) and decoded.flags.c_contiguous
    rows = _rows(batches)
    assert rows.flags.c_contiguous and rows.dtype == np.float64 and rows.shape == (9, 500)
    assert np.array_equal(rows[3:6], batches[1].xyz.T)


@contextmanager
def live_listener(cli_env, *listen_args: str):
    """`hav broker` and `hav listen` (with ``listen_args``) as separate processes on a free port; yields (port,
    broker, listener, the listener's output lines, their reader thread) once it listens; both stopped after."""
    port, env = free_port(), {**os.environ, **cli_env, "PYTHONUNBUFFERED": "1"}
    broker = subprocess.Popen([sys.executable, "-m", "bim2rdt", "hav", "broker", "--port", str(port), "--devices",
                               "1", "--duration", "120"], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True)
    listener = None
    try:
        follow(broker, "mosquitto on", timeout=30)
        listener = subprocess.Popen([sys.executable, "-m", "bim2rdt", "hav", "listen", "--mqtt", f"127.0.0.1:{port}",
                                     *listen_args], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        out, reader = follow(listener, "listening on", timeout=30)  # printed once its subscriptions are acked
        yield port, broker, listener, out, reader
    finally:
        for process in (listener, broker):
            if process is not None and process.poll() is None:
                process.terminate()
                try:
                    process.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    process.kill()


def test_a_live_run_through_mosquitto_with_the_shipped_config(tmp_path, cli_env):
    with live_listener(cli_env, "--duration", "12") as (port, broker, listener, out, reader):
        sim = run_cli("sim", "wearables", "--mqtt", f"127.0.0.1:{port}", "--workers", "1", "--minutes", "1",
                      "--fs", "1000", env=cli_env)
        assert sim.returncode == 0, sim.stderr
        assert listener.wait(timeout=60) == 0, listener.stderr.read()
        reader.join(timeout=10)
        text = "".join(out)
        assert "activity_started" in text and "activity_ended" in text
        broker.terminate()
        assert broker.wait(timeout=10) == 0
        assert not _listening(port)  # the command stopped its mosquitto: nothing left running


def _listening(port: int) -> bool:
    try:
        socket.create_connection(("127.0.0.1", port), timeout=1.0).close()
        return True
    except OSError:
        return False


def follow(process: subprocess.Popen, text: str, timeout: float) -> tuple[list[str], threading.Thread]:
    """Read ``process``'s stdout on a thread; return once a line holds ``text``, fail (never hang) after
    ``timeout`` s. Returns the lines (the thread keeps adding the rest of the output) and the thread."""
    lines: list[str] = []
    seen = threading.Event()

    def read() -> None:
        for line in process.stdout:
            lines.append(line)
            if text in line:
                seen.set()

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    if not seen.wait(timeout):
        pytest.fail(f"{process.args[3:5]} printed no {text!r} within {timeout} s: {''.join(lines)[-300:]!r}")
    return lines, reader


def test_analyze_uses_the_live_monitors_settings_from_the_environment(tmp_path):
    fs = 2000.0
    signal = session_signal([("idle", 3), ("grinder", 20), ("idle", 5)], fs, a_hv={"grinder": 6.0})
    path = write_accel_csv(tmp_path / "day.csv", signal, fs)
    default = run_cli("hav", "analyze", str(path), "--out", str(tmp_path), "--json")
    raised = run_cli("hav", "analyze", str(path), "--out", str(tmp_path), "--json",
                     env={"BIM2RDT_HAV__START_THRESHOLD": "8", "BIM2RDT_HAV__STOP_THRESHOLD": "4"})
    assert default.returncode == raised.returncode == 0, default.stderr + raised.stderr
    assert len(json.loads(default.stdout)["activities"]) == 1
    assert json.loads(raised.stdout)["activities"] == []  # a 6 m/s^2 grinder is under an 8 m/s^2 trigger


@pytest.mark.parametrize("target", ["folder", "", "/proc/twin.ifc", "under-a-file"])
def test_a_twin_target_that_cannot_be_written_fails_before_the_simulation(tmp_path, cli_env, target):
    site = build_site_ifc(tmp_path / "site.ifc")
    (tmp_path / "folder").mkdir()
    (tmp_path / "file").write_text("not a folder")
    out = {"folder": str(tmp_path / "folder"), "under-a-file": str(tmp_path / "file" / "twin.ifc")}.get(target, target)
    result = run_cli("sim", "wearables", "--workers", "3", "--minutes", "600", "--ifc", str(site), "--out", out,
                     env=cli_env, timeout=60)  # 10 hours of simulation if the check came after the run
    assert result.returncode == 1 and len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert "twin" in result.stderr or "folder" in result.stderr
    assert "activity_started" not in result.stdout


def _special(tmp_path, kind: str) -> Path:
    """A twin target the atomic write would refuse to replace: a symlink, a device node or a FIFO."""
    if kind == "symlink":
        (tmp_path / "elsewhere.ifc").write_text("keep me")
        (tmp_path / "link.ifc").symlink_to(tmp_path / "elsewhere.ifc")
        return tmp_path / "link.ifc"
    if kind == "fifo":
        os.mkfifo(tmp_path / "pipe.ifc")
        return tmp_path / "pipe.ifc"
    return Path("/dev/full")


@pytest.mark.parametrize("kind", ["symlink", "device", "fifo"])
def test_a_twin_target_that_is_no_regular_file_fails_before_the_run(tmp_path, cli_env, kind):
    site = build_site_ifc(tmp_path / "site.ifc")
    out = str(_special(tmp_path, kind))
    simulated = run_cli("sim", "wearables", "--workers", "3", "--minutes", "600", "--ifc", str(site), "--out", out,
                        env=cli_env, timeout=60)  # 10 hours of simulation if the check came after the run
    listened = run_cli("hav", "listen", "--mqtt", "127.0.0.1:1", "--ifc", str(site), "--out", out, env=cli_env)
    for result in (simulated, listened):  # listen: nothing listens on port 1, so connecting first would fail there
        assert result.returncode == 1 and len(result.stderr.strip().splitlines()) == 1, result.stderr
        assert {"symlink": "symlink", "device": "character device", "fifo": "FIFO"}[kind] in result.stderr
    assert "activity_started" not in simulated.stdout
    if kind == "symlink":
        assert (tmp_path / "elsewhere.ifc").read_text() == "keep me"


def test_hav_listen_checks_the_twin_target_before_connecting(tmp_path, cli_env):
    site = build_site_ifc(tmp_path / "site.ifc")
    result = run_cli("hav", "listen", "--mqtt", "127.0.0.1:1", "--ifc", str(site), "--out", str(tmp_path),
                     env=cli_env)  # nothing listens on port 1: had it connected first, that would be the error
    assert result.returncode == 1 and "is a folder" in result.stderr


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_hav_listen_stopped_by_a_signal_prints_the_day_and_exits_0(tmp_path, cli_env, signum):
    """A supervisor stops the monitor with SIGTERM (Ctrl-C is SIGINT): it commits, prints the day and exits 0. The
    devices on the way run on clocks counting from boot and restart once: the store shows the restart counted
    (announced by the simulator's boot ids), nothing dropped, the exposure on today's date."""
    with live_listener(cli_env) as (port, _, listener, out, reader):
        sim = run_cli("sim", "wearables", "--mqtt", f"127.0.0.1:{port}", "--workers", "1", "--minutes", "1",
                      "--fs", "1000", "--device-clock", "boot", "--reboot-after", "0.5", env=cli_env)
        assert sim.returncode == 0, sim.stderr
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and "".join(out).count("activity_ended") < 3:  # one per tool
            time.sleep(0.2)
        listener.send_signal(signum)
        assert listener.wait(timeout=30) == 0, listener.stderr.read()
        reader.join(timeout=10)
        text = "".join(out)
        assert text.count("activity_ended") == 3 and "Daily exposure" in text and "w1" in text.split("Daily")[1]
    monitor = HavMonitor(tmp_path / "var" / "hav", "test-site", [], MonitorConfig(site="t"))
    subject, status = monitor.queries.session("w1").subject, monitor.queries.stream_status("w1")
    days = monitor.queries.days_of(subject)
    monitor.close()
    assert status["restarts"] == 1 and status.get("duplicates", 0) == 0 and status["time_base"] == "receive"
    assert days == [time.strftime("%Y-%m-%d", time.gmtime())]
