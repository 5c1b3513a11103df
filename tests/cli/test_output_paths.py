"""Commands that write files (`site`, `demo`, `bench registration`) check the output path before the work, and
every way a write can fail (a folder, an empty path, /proc, a device, a full disk) is one line, never a
traceback, with the previous file kept.

Full disks are simulated with RLIMIT_FSIZE in the child (the kernel answers EFBIG, "File too large") and, where
the tests run as root with mount rights, a small tmpfs in a private mount namespace (the real ENOSPC).
"""

from __future__ import annotations

import os
import resource
import shutil
import stat
import subprocess
import sys

import pytest

OLD = "the previous file\n"


def run_cli(*args: str, fsize_limit: int | None = None, mount: str = "") -> subprocess.CompletedProcess:
    def limit() -> None:
        if fsize_limit is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (fsize_limit, fsize_limit))

    command = [sys.executable, "-m", "bim2rdt", *args]
    if mount:
        command = ["unshare", "-m", "sh", "-c", f'{mount} && exec "$@"', "sh", *command]
    return subprocess.run(command, capture_output=True, text=True, timeout=600, preexec_fn=limit)


def _one_line(result: subprocess.CompletedProcess, code: int = 1) -> str:
    assert result.returncode == code, result.stderr
    assert "Traceback" not in result.stderr and result.stderr.strip().count("\n") == 0, result.stderr
    return result.stderr.strip()


@pytest.mark.parametrize("where, expected", [
    ("{tmp}", "it is a folder, not a file"),
    ("/proc", "/proc: it is a folder, not a file"),
    ("/proc/site.ifc", "cannot create a file in /proc"),
    ("{tmp}/missing/site.ifc", "the folder {tmp}/missing does not exist"),
])
def test_site_onto_a_path_that_cannot_take_a_file_is_one_line(tmp_path, where, expected):
    message = _one_line(run_cli("site", where.format(tmp=tmp_path)))
    assert message.startswith("error: cannot write ") and expected.format(tmp=tmp_path) in message


@pytest.mark.parametrize("command", [("site",), ("demo", "--out"), ("bench", "registration", "--out"),
                                     ("plan", "site.ifc", "--out"), ("twin", "export", "site.ifc", "--out"),
                                     ("hav", "analyze", "day.csv", "--out")])
def test_an_empty_output_path_is_a_usage_error_not_the_current_folder(tmp_path, command):
    result = subprocess.run([sys.executable, "-m", "bim2rdt", *command, ""], capture_output=True, text=True,
                            timeout=120, cwd=tmp_path)
    assert result.returncode == 2 and "an empty path" in result.stderr
    assert result.stderr.startswith("error: ") and len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert os.listdir(tmp_path) == []


def test_site_onto_an_existing_file_keeps_its_permissions(tmp_path):
    target = tmp_path / "site.ifc"
    target.write_text(OLD)
    target.chmod(0o640)
    assert run_cli("site", str(target)).returncode == 0
    assert stat.S_IMODE(target.stat().st_mode) == 0o640 and target.read_text().startswith("ISO-10303-21;")


def test_site_refuses_a_symlink_or_fifo_unless_forced(tmp_path):
    real = tmp_path / "real.ifc"
    real.write_text(OLD)
    (tmp_path / "link.ifc").symlink_to(real)
    os.mkfifo(tmp_path / "fifo.ifc")
    for name, kind in (("link.ifc", "symlink"), ("fifo.ifc", "FIFO")):
        message = _one_line(run_cli("site", str(tmp_path / name)))
        assert f"it is a {kind}, not a regular file; refusing to replace it (--force replaces it)" in message
        assert run_cli("site", "--force", str(tmp_path / name)).returncode == 0
        assert stat.S_ISREG((tmp_path / name).lstat().st_mode)
    assert real.read_text() == OLD


def test_site_onto_a_full_disk_is_one_line_and_keeps_the_old_file(tmp_path):
    target = tmp_path / "site.ifc"
    target.write_text(OLD)
    message = _one_line(run_cli("site", str(target), fsize_limit=100_000))
    assert message == f"error: cannot write {target}: File too large; the previous file is unchanged"
    assert target.read_text() == OLD and os.listdir(tmp_path) == ["site.ifc"]


def test_demo_onto_a_full_disk_is_one_line(tmp_path):
    message = _one_line(run_cli("demo", "--out", str(tmp_path / "demo"), "--trials", "1", "--minutes", "1",
                                fsize_limit=200_000))
    assert message == f"error: cannot write {tmp_path}/demo/site.ifc: File too large; nothing was written"


def test_demo_onto_a_really_full_tmpfs_is_one_line(tmp_path):
    """The site IFC fits in 1 MiB and the exposure store then fills it: SQLite's error reaches the CLI's edge."""
    folder = tmp_path / "small"
    folder.mkdir()
    probe = ["unshare", "-m", "mount", "-t", "tmpfs", "tmpfs", str(folder)]
    if os.geteuid() != 0 or shutil.which("unshare") is None or subprocess.run(probe).returncode != 0:
        pytest.skip("mounting a tmpfs needs root with mount rights (unshare -m); the RLIMIT_FSIZE test covers it")
    result = run_cli("demo", "--out", str(folder / "demo"), "--trials", "1", "--minutes", "1",
                     mount=f"mount -t tmpfs -o size=1m tmpfs {folder}")
    message = _one_line(result)
    assert message.startswith("error: ") and ("disk is full" in message or "No space left on device" in message)
