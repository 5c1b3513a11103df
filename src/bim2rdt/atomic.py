"""Atomic file writes: a temporary file in the target folder, fsync, then rename over the target, so a reader
never sees half a file and a crash, a full disk or a read-only folder leaves the old one.

Every OS error becomes a one-line ``WriteError`` naming the path. The rename replaces whatever the path names,
so a symlink, a device node (``/dev/full``), a FIFO or a socket there is refused unless the caller passes
``replace_special=True`` (then it is replaced by a regular file; the link's target or the device is untouched).
An existing file keeps its permission bits; a new one gets the usual ``0o666 & ~umask``.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import stat
import tempfile
from pathlib import Path

from bim2rdt.errors import Bim2RdtError


class WriteError(Bim2RdtError):
    """A file could not be written (the previous one, if any, is unchanged); one line naming the path."""


class NotRegularFileError(WriteError):
    """The path names a symlink or special file, which a write would replace; allowed by ``replace_special``."""


def check_writable_file(path: Path, *, replace_special: bool = False) -> Path:
    """Check now, before long work, that ``path`` can take an atomic write: it is not a folder (nor empty),
    its folder exists and takes a file, and it names no symlink or special file (unless ``replace_special``).

    Args:
        path: The file the caller will write later.
        replace_special: Allow a symlink, device node, FIFO or socket at ``path`` (the write replaces it).

    Returns:
        ``path`` as a ``Path``.

    Raises:
        WriteError: The folder is missing or takes no file, or ``path`` is a folder.
        NotRegularFileError: ``path`` names a symlink or special file and ``replace_special`` is False.
    """
    path = Path(path)
    _check_target(path, replace_special)
    if not path.parent.is_dir():
        raise WriteError(f"cannot write {path}: the folder {path.parent} does not exist")
    try:
        tempfile.TemporaryFile(dir=path.parent).close()
    except OSError as error:
        raise WriteError(f"cannot write {path}: cannot create a file in {path.parent}: {_reason(error)}") from error
    return path


def write_bytes_atomic(path: Path, data: bytes, *, replace_special: bool = False) -> Path:
    """Write ``data`` to ``path`` atomically: a temporary file in the same folder, fsync, then rename over it.

    Args:
        path: The target file; missing parent folders are created.
        data: The whole new content.
        replace_special: Allow replacing a symlink or special file at ``path`` by a regular file.

    Returns:
        ``path`` as a ``Path``.

    Raises:
        WriteError: Any OS error (full disk, read-only folder, ...); the previous file, if any, is unchanged.
        NotRegularFileError: ``path`` names a symlink or special file and ``replace_special`` is False.
    """
    path = Path(path)
    mode = _check_target(path, replace_special)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise WriteError(f"cannot write {path}: cannot create {path.parent}: {_reason(error)}") from error
    temporary = path.parent / f".{path.name}.{secrets.token_hex(4)}.tmp"
    try:
        _write_new(temporary, data, mode)
        os.replace(temporary, path)
    except OSError as error:
        _discard(temporary)
        raise WriteError(f"cannot write {path}: {_reason(error)}; {_kept(path)}") from error
    except BaseException:
        _discard(temporary)
        raise
    return path


def _check_target(path: Path, replace_special: bool) -> int | None:
    """Refuse what a rename must not replace; the permission bits of an existing regular file, else None."""
    if not path.name:
        raise WriteError(f"cannot write {str(path)!r}: the path is empty or names a folder")
    try:
        info = path.lstat()
    except FileNotFoundError:
        return None
    except OSError as error:
        raise WriteError(f"cannot write {path}: {_reason(error)}") from error
    if stat.S_ISDIR(info.st_mode):
        raise WriteError(f"cannot write {path}: it is a folder, not a file")
    if not stat.S_ISREG(info.st_mode) and not replace_special:
        raise NotRegularFileError(f"cannot write {path}: it is a {_kind(info.st_mode)}, not a regular file; "
                                  "refusing to replace it")
    return stat.S_IMODE(info.st_mode) if stat.S_ISREG(info.st_mode) else None


def _write_new(temporary: Path, data: bytes, mode: int | None) -> None:
    descriptor = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)  # the umask applies
    with os.fdopen(descriptor, "wb") as stream:
        if mode is not None:
            os.fchmod(stream.fileno(), mode)
        stream.write(data)
        stream.flush()
        os.fsync(stream.fileno())


def _discard(temporary: Path) -> None:
    """Remove a half-written temporary file; on a read-only or vanished folder there is none to remove, and
    the unlink's own error (EROFS, EACCES) must not hide the write's."""
    with contextlib.suppress(OSError):
        temporary.unlink(missing_ok=True)


def _kind(mode: int) -> str:
    kinds = [(stat.S_ISLNK, "symlink"), (stat.S_ISCHR, "character device"), (stat.S_ISBLK, "block device"),
             (stat.S_ISFIFO, "FIFO"), (stat.S_ISSOCK, "socket")]
    return next((name for test, name in kinds if test(mode)), "special file")


def _kept(path: Path) -> str:
    return "the previous file is unchanged" if path.exists() else "nothing was written"


def _reason(error: OSError) -> str:
    return error.strerror or str(error)
