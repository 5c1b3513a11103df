"""Atomic writes fail in one line and keep the old file, keep its permissions, and never replace a symlink or a
device node by accident.

A full disk is simulated two honest ways: RLIMIT_FSIZE in a child process (the kernel refuses the write with
EFBIG, "File too large"; always available), and, where the tests run as root with mount rights, a 64 KiB tmpfs
mounted in a private mount namespace (`unshare -m`), which gives the real ENOSPC.
"""

from __future__ import annotations

import os
import resource
import shutil
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from bim2rdt.atomic import NotRegularFileError, WriteError, check_writable_file, write_bytes_atomic
from bim2rdt.errors import Bim2RdtError

OLD = b"the previous file\n"
BIG = b"x" * 1_000_000


def _write_in_child(target, data_size: int, *, fsize_limit: int | None = None, shell_prefix: str = ""):
    """Run write_bytes_atomic(target, data_size bytes) in a child; (exit code, stdout+stderr)."""
    code = textwrap.dedent(f"""
        from pathlib import Path
        from bim2rdt.atomic import WriteError, write_bytes_atomic
        try:
            write_bytes_atomic(Path({str(target)!r}), b"y" * {data_size})
        except WriteError as error:
            print("WriteError:", error)
            raise SystemExit(1)
        print("written")
    """)

    def limit() -> None:
        if fsize_limit is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (fsize_limit, fsize_limit))

    command = [sys.executable, "-c", code]
    if shell_prefix:
        command = ["unshare", "-m", "sh", "-c", f'{shell_prefix} && exec "$@"', "sh", *command]
    result = subprocess.run(command, capture_output=True, text=True, timeout=120, preexec_fn=limit)
    return result.returncode, result.stdout + result.stderr


def _can_mount_tmpfs(folder) -> bool:
    if os.geteuid() != 0 or shutil.which("unshare") is None:
        return False
    probe = subprocess.run(["unshare", "-m", "mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(folder)],
                           capture_output=True)
    return probe.returncode == 0


def test_a_write_error_is_a_project_error_so_the_cli_prints_one_line():
    assert issubclass(WriteError, Bim2RdtError) and issubclass(NotRegularFileError, WriteError)


def test_a_full_disk_is_one_line_and_the_old_file_is_kept(tmp_path):
    target = tmp_path / "site.ifc"
    target.write_bytes(OLD)
    code, output = _write_in_child(target, len(BIG), fsize_limit=100_000)
    assert code == 1, output
    assert output.strip() == f"WriteError: cannot write {target}: File too large; the previous file is unchanged"
    assert target.read_bytes() == OLD and os.listdir(tmp_path) == ["site.ifc"]  # no temp file left


def test_a_really_full_tmpfs_is_one_line_and_the_old_file_is_kept(tmp_path):
    folder = tmp_path / "small"
    folder.mkdir()
    if not _can_mount_tmpfs(folder):
        pytest.skip("mounting a tmpfs needs root with mount rights (unshare -m); the RLIMIT_FSIZE test covers it")
    mount = f"mount -t tmpfs -o size=64k tmpfs {folder} && printf 'old' > {folder}/site.ifc"
    code, output = _write_in_child(folder / "site.ifc", 200_000, shell_prefix=mount + f" && cat {folder}/site.ifc")
    assert code == 1, output
    assert output == (f"oldWriteError: cannot write {folder}/site.ifc: No space left on device; "
                      "the previous file is unchanged\n")


def test_a_read_only_folder_is_one_line_and_the_old_file_is_kept(tmp_path):
    folder = tmp_path / "locked"
    folder.mkdir()
    (folder / "site.ifc").write_bytes(OLD)
    if os.geteuid() != 0:
        folder.chmod(0o555)
        code, output = _write_in_child(folder / "site.ifc", 10)
        folder.chmod(0o755)
        reason = "Permission denied"
    elif _can_mount_tmpfs(folder):  # root ignores permission bits: a read-only mount is what refuses it
        remount = (f"mount -t tmpfs tmpfs {folder} && printf 'old' > {folder}/site.ifc && "
                   f"mount -o remount,ro {folder}")
        code, output = _write_in_child(folder / "site.ifc", 10, shell_prefix=remount + f" && cat {folder}/site.ifc")
        output, reason = output.removeprefix("old"), "Read-only file system"
    else:
        pytest.skip("as root, a read-only folder needs a read-only mount (unshare -m), which is not permitted here")
    assert code == 1
    assert output.strip() == f"WriteError: cannot write {folder}/site.ifc: {reason}; the previous file is unchanged"
    assert (folder / "site.ifc").read_bytes() == OLD


def test_writing_over_a_file_keeps_its_permission_bits(tmp_path):
    target = tmp_path / "shared.ifc"
    target.write_bytes(OLD)
    target.chmod(0o640)
    write_bytes_atomic(target, b"new")
    assert target.read_bytes() == b"new" and stat.S_IMODE(target.stat().st_mode) == 0o640


def test_a_new_file_gets_the_usual_mode_not_a_private_temp_files(tmp_path):
    umask = os.umask(0o022)
    try:
        write_bytes_atomic(tmp_path / "new.ifc", b"new")
    finally:
        os.umask(umask)
    assert stat.S_IMODE((tmp_path / "new.ifc").stat().st_mode) == 0o644


def _special_files(tmp_path):
    real = tmp_path / "real.ifc"
    real.write_bytes(OLD)
    (tmp_path / "link.ifc").symlink_to(real)
    os.mkfifo(tmp_path / "fifo.ifc")
    made = {"symlink": tmp_path / "link.ifc", "FIFO": tmp_path / "fifo.ifc"}
    if os.geteuid() == 0:  # a device node like /dev/null's (1, 3), made in the test folder
        os.mknod(tmp_path / "null.ifc", 0o666 | stat.S_IFCHR, os.makedev(1, 3))
        made["character device"] = tmp_path / "null.ifc"
    return real, made


def test_a_symlink_or_special_file_is_refused_and_left_alone(tmp_path):
    real, special = _special_files(tmp_path)
    for kind, path in special.items():
        before = path.lstat()
        for attempt in (lambda: write_bytes_atomic(path, b"new"), lambda: check_writable_file(path)):
            with pytest.raises(NotRegularFileError, match=f"^cannot write {path}: it is a {kind}, not a regular"):
                attempt()
        assert path.lstat().st_mode == before.st_mode and path.lstat().st_ino == before.st_ino
    assert real.read_bytes() == OLD


def test_replace_special_replaces_the_link_or_node_with_a_regular_file(tmp_path):
    real, special = _special_files(tmp_path)
    for path in special.values():
        write_bytes_atomic(path, b"new", replace_special=True)
        assert stat.S_ISREG(path.lstat().st_mode) and path.read_bytes() == b"new"
    assert real.read_bytes() == OLD  # the link's target is untouched


@pytest.mark.parametrize("where", ["a folder", "empty", "the root"])
def test_a_folder_or_an_empty_path_is_one_write_error(tmp_path, where):
    path = {"a folder": tmp_path, "empty": Path(""), "the root": Path("/")}[where]
    with pytest.raises(WriteError, match="^cannot write .*(folder|empty)"):
        write_bytes_atomic(path, b"new")


def test_check_writable_file_names_a_missing_folder_and_proc(tmp_path):
    with pytest.raises(WriteError, match="the folder .*missing does not exist"):
        check_writable_file(tmp_path / "missing" / "site.ifc")
    with pytest.raises(WriteError, match="^cannot write /proc/site.ifc: cannot create a file in /proc: "):
        check_writable_file(Path("/proc/site.ifc"))
    assert check_writable_file(tmp_path / "site.ifc") == tmp_path / "site.ifc" and os.listdir(tmp_path) == []


def test_parent_folders_are_created(tmp_path):
    assert write_bytes_atomic(tmp_path / "a" / "b" / "c.json", b"{}").read_bytes() == b"{}"
