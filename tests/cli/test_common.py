"""`--out` folders are checked before a long run: a path that cannot take files fails at once, in one line."""

from __future__ import annotations

import subprocess
import sys

import pytest


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "bim2rdt", *args], capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("command", [("bench", "registration", "--trials", "1", "--no-peers"),
                                     ("demo", "--trials", "1")])
def test_an_out_folder_that_is_a_file_is_refused_in_one_line_before_the_run(tmp_path, command):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    result = run_cli(*command, "--out", str(blocker / "sub"))
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    assert "--out" in result.stderr and "cannot write into" in result.stderr
    assert not list(tmp_path.glob("**/*.png"))


def test_writable_folder_creates_the_folder_and_returns_it(tmp_path):
    from bim2rdt.cli.common import writable_folder

    folder = tmp_path / "a" / "b"
    assert writable_folder(folder) == folder and folder.is_dir()
    assert list(folder.iterdir()) == []  # the probe file is gone


@pytest.mark.parametrize("command", [("bench", "registration", "--no-peers"), ("demo",)])
def test_a_negative_seed_is_a_usage_error_not_a_numpy_traceback(tmp_path, command):
    result = run_cli(*command, "--trials", "1", "--seed", "-1", "--out", str(tmp_path))
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert "'--seed'" in result.stderr
