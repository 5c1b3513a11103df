"""verify's progress on a bag that knows its length: piped (not a terminal), one plain line per stage with its
count; on a terminal (a pseudo-terminal here), a live bar with the frames counted and the time left."""

from __future__ import annotations

import os
import pty
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

import bim2rdt
from bim2rdt.cli import app
from bim2rdt.sim.site import build_site_ifc
from tests.sources.bags import write_bag

runner = CliRunner()
FRAMES = 4


@pytest.fixture(scope="module")
def small_bag(tmp_path_factory):
    """The default site and a bag of ``FRAMES`` small frames (random depth: each is refused at once, so the
    frames go by quickly)."""
    folder = tmp_path_factory.mktemp("progress")
    write_bag(folder / "small.mcap", [1.0 + k for k in range(FRAMES)])
    return build_site_ifc(folder / "site.ifc"), folder / "small", folder


def test_piped_verify_prints_one_plain_line_per_stage_with_its_count(small_bag):
    ifc, bag, folder = small_bag
    result = runner.invoke(app, ["verify", str(ifc), str(bag), "--out", str(folder / "piped"), "--detector", "none"])
    assert result.exit_code == 3, result.output  # random depth: no frame localized (NO_FIX_EXIT), the run finished
    lines = result.output.splitlines()
    frames = [line for line in lines if "frames verified" in line]
    assert len(frames) == 1 and re.match(rf"\[\d\d:\d\d\] frames verified: {FRAMES}/{FRAMES} done in \d+ s$",
                                         frames[0]), frames
    assert sum("twin recorded and exported: done in" in line for line in lines) == 1
    assert "\x1b[" not in result.output  # no terminal control codes in a log


def test_on_a_terminal_verify_shows_a_bar_with_the_frames_counted_and_the_time_left(small_bag):
    ifc, bag, folder = small_bag
    main, terminal = pty.openpty()
    env = {**os.environ, "COLUMNS": "150", "LINES": "40", "TERM": "xterm-256color",
           "PYTHONPATH": os.pathsep.join([str(Path(bim2rdt.__file__).resolve().parents[1]),  # the code under test
                                          os.environ.get("PYTHONPATH", "")])}
    env.pop("NO_COLOR", None)
    process = subprocess.Popen([sys.executable, "-m", "bim2rdt", "verify", str(ifc), str(bag), "--out",
                                str(folder / "terminal"), "--detector", "none"], stdin=terminal, stdout=terminal,
                               stderr=terminal, env=env, close_fds=True)
    os.close(terminal)
    shown = _read_all(main, process)
    assert process.wait() == 3, shown[-2000:]  # no frame localized, as above
    text = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", shown)
    assert re.search(rf"frames verified .*\b[1-{FRAMES}]/{FRAMES}\b", text), text[-2000:]
    assert re.search(r"left\s+\d+:\d\d:\d\d", text), text[-2000:]  # an estimate, not the '-:--:--' placeholder


def _read_all(fd: int, process: subprocess.Popen, timeout: float = 120.0) -> str:
    chunks, deadline = [], time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            chunk = os.read(fd, 65536)
        except OSError:  # the child closed the terminal
            break
        if not chunk:
            break
        chunks.append(chunk)
    os.close(fd)
    return b"".join(chunks).decode("utf-8", "replace")
