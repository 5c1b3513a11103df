"""A command stopped by Ctrl-C or a supervisor's SIGTERM says so in one line and exits 130 or 143 (never 0: `make`
and scripts would take the cut run for a success), and its output folder says it is partial. (That a failed run
leaves no empty folder it made is checked in test_demo_every_ifc.py, on its run of the building with no floor.)"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from bim2rdt.cli import common
from bim2rdt.cli.common import INCOMPLETE_MARKER, close_run_folders, run_folder


@pytest.fixture(autouse=True)
def _no_run_folders_left():
    yield
    common._run_folders.clear()


def start_demo(out, log) -> subprocess.Popen:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}  # as `| tee` gets it: block-buffered
    return subprocess.Popen([sys.executable, "-m", "bim2rdt", "demo", "--out", str(out)], stdout=log,
                            stderr=subprocess.PIPE, text=True, env=env)


def wait_for(done, process, seconds=300.0) -> None:
    end = time.monotonic() + seconds
    while not done():
        assert process.poll() is None, process.communicate()
        assert time.monotonic() < end, "the run never got there"
        time.sleep(0.2)


@pytest.mark.parametrize(("stop", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_demo_stopped_by_a_signal_says_so_in_one_line_and_exits_non_zero(tmp_path, stop, code):
    """Under way: its output piped (no terminal) already shows the first stage done, as a plain line."""
    out, log = tmp_path / "demo", tmp_path / "stdout.log"
    with log.open("w") as stdout:
        process = start_demo(out, stdout)
        wait_for(lambda: "site model read: done in" in log.read_text(), process)
        process.send_signal(stop)
        _, stderr = process.communicate(timeout=60)
    assert process.returncode == code, (log.read_text(), stderr)
    assert "Traceback" not in stderr
    assert stderr.strip().splitlines()[-1] == f"interrupted; partial output in {out}"
    assert "incomplete" in (out / INCOMPLETE_MARKER).read_text()


def test_an_interrupted_run_removes_the_empty_folder_it_made_and_marks_one_with_files(tmp_path):
    empty, filled, existing = tmp_path / "empty", tmp_path / "filled", tmp_path / "existing"
    existing.mkdir()
    for folder in (empty, filled, existing):
        run_folder(folder)
    (filled / "site.ifc").write_text("part")
    assert close_run_folders("was interrupted") == [filled, existing]
    assert not empty.exists()
    assert "was interrupted" in (filled / INCOMPLETE_MARKER).read_text()
    assert existing.is_dir() and (existing / INCOMPLETE_MARKER).is_file()  # not ours to remove: marked


def test_a_new_run_into_a_marked_folder_clears_the_old_mark(tmp_path):
    (tmp_path / INCOMPLETE_MARKER).write_text("incomplete: the run was interrupted")
    run_folder(tmp_path)
    assert not (tmp_path / INCOMPLETE_MARKER).exists()
