"""`hav listen --nats --partitions N` after a kill -9 of its supervisor: its monitors and standby end with it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from tests.bus.conftest import NATS_MONITORS, SITE
from tests.bus.test_nats_live import Output


def alive(pid: int) -> bool:
    """The process runs (a zombie waiting for its reaper does not)."""
    try:
        return Path(f"/proc/{pid}/status").read_text().split("State:")[1].split()[0] != "Z"
    except (FileNotFoundError, IndexError):
        return False


def children_of(pid: int) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if Path(entry, "stat").read_text().rsplit(")", 1)[1].split()[1] == str(pid):
                    found.append(int(entry.name))
            except (FileNotFoundError, IndexError):
                continue
    return found


def test_the_monitors_of_a_supervisor_killed_with_sigkill_stop_instead_of_consuming_as_orphans(nats_server, tmp_path):
    env = {**os.environ, "BIM2RDT_DATA_DIR": str(tmp_path / "data"), "BIM2RDT_MQTT__SITE": SITE,
           "BIM2RDT_MQTT__USERNAME": "monitor", "BIM2RDT_MQTT__PASSWORD": NATS_MONITORS["monitor"],
           "BIM2RDT_HAV__SITE_SECRET": "supervised-secret", "PYTHONUNBUFFERED": "1", "COLUMNS": "200"}
    supervisor = subprocess.Popen([sys.executable, "-m", "bim2rdt", "hav", "listen", "--nats", nats_server.url,
                                   "--partitions", "2"], env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                  text=True)
    out, monitors = Output(supervisor), []
    try:
        for k in range(2):
            out.wait_for(rf"partition {k}/2 of site .* \(pid (\d+)\)", 90)
        monitors = children_of(supervisor.pid)
        assert len(monitors) == 3  # two partitions and the warm standby
        os.kill(supervisor.pid, signal.SIGKILL)
        supervisor.wait(timeout=10)
        deadline = time.monotonic() + 30
        while any(alive(pid) for pid in monitors) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert [pid for pid in monitors if alive(pid)] == []
    finally:
        for pid in monitors + children_of(supervisor.pid) + [supervisor.pid]:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
