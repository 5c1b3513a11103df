"""verify's outputs as one set: a run writes into a staging folder inside ``--out`` and moves the whole set into
place when it ends, so ``--out`` holds one run's files, never two runs' mixed.

- While the run works, only ``OUT/.verify-run-PID-XXXX/`` changes; the earlier run's files stay as they were.
- :meth:`OutputSet.commit` moves the set in with the stop signals held back (a Ctrl-C then lands after it), and
  first removes every output name this run did not write (an IFC2X3 model's run leaves no earlier ``twin.ifc``).
- A run that fails or is interrupted discards its staging folder: ``--out`` keeps the earlier run's set
  unchanged. A staging folder left by a killed process (its PID gone) is removed by the next run.

Only the names of :data:`OUTPUT_NAMES` are ever removed from ``--out``: it may be a folder with the user's own
files.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import shutil
import signal
from collections.abc import Iterator, Sequence
from pathlib import Path

from bim2rdt.verify.errors import VerifyError

OUTPUT_NAMES = ("twin.db", "twin.json", "twin.ifc", "issues.bcf", "localization.json", "report.html", "config.json",
                "structure.json", "deviation.ply", "deviation", "progress.json", "progress_curve.json",
                "progress_structure.png", "maps")
"""Every file or folder a verify run may write into ``--out``; what the run did not write is removed at commit."""
STAGING_PREFIX = ".verify-run-"
_SIDE_FILES = ("twin.db-wal", "twin.db-shm", "twin.db-journal")


class OutputSet:
    """The staging folder of one run in ``out_dir`` (a context manager: it discards the folder on any exception,
    an interrupt included, unless the set was committed).

    Args:
        out_dir: ``--out``; it must exist.
        names: The output names a commit moves in, or removes when the run did not write them.
    """

    def __init__(self, out_dir: Path, names: Sequence[str] = OUTPUT_NAMES) -> None:
        self.out_dir, self.names = Path(out_dir), tuple(names)
        self.staging: Path | None = None
        self.committed: list[str] = []

    def __enter__(self) -> OutputSet:
        remove_abandoned(self.out_dir)
        self.staging = self.out_dir / f"{STAGING_PREFIX}{os.getpid()}-{secrets.token_hex(3)}"
        try:
            self.staging.mkdir()
        except OSError as error:
            raise VerifyError(f"cannot write into {self.out_dir}: {error.strerror or error}") from None
        return self

    def __exit__(self, kind, error, trace) -> None:
        self.discard()

    @property
    def folder(self) -> Path:
        """The staging folder, where the run writes its files."""
        if self.staging is None:
            raise VerifyError("the output set is not open (use it in a with block)")
        return self.staging

    def previous(self) -> list[str]:
        """The output names ``out_dir`` holds now (an earlier run's, before a commit), sorted."""
        return sorted(name for name in self.names if (self.out_dir / name).exists())

    def commit(self) -> list[str]:
        """Move the staged set into ``out_dir``: first every output name this run did not write goes, then each
        staged file replaces its namesake. Stop signals wait until it is done.

        Returns:
            The names moved in, sorted.
        """
        written = sorted(name for name in self.names if (self.folder / name).exists())
        side = [name for name in _SIDE_FILES if (self.folder / name).exists()]  # a database not checkpointed
        with _signals_held():
            for name in (*self.names, *_SIDE_FILES):
                if name not in written and name not in side:
                    _remove(self.out_dir / name)
            for name in (*written, *side):
                target = self.out_dir / name
                if target.is_dir() and not target.is_symlink():
                    shutil.rmtree(target)
                os.replace(self.folder / name, target)
        self.committed = written
        self.discard()
        return written

    def discard(self) -> None:
        """Remove the staging folder and whatever it still holds (nothing after a commit)."""
        if self.staging is not None:
            shutil.rmtree(self.staging, ignore_errors=True)


def remove_abandoned(out_dir: Path) -> list[Path]:
    """Remove the staging folders in ``out_dir`` whose process is gone (killed before it could tidy up).

    Args:
        out_dir: ``--out``.

    Returns:
        The folders removed.
    """
    removed = []
    for folder in Path(out_dir).glob(f"{STAGING_PREFIX}*"):
        pid = folder.name[len(STAGING_PREFIX):].split("-")[0]
        if folder.is_dir() and pid.isdigit() and not _alive(int(pid)):
            shutil.rmtree(folder, ignore_errors=True)
            removed.append(folder)
    return removed


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process
        return True
    return True


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    else:
        path.unlink(missing_ok=True)


@contextlib.contextmanager
def _signals_held() -> Iterator[None]:
    """SIGINT, SIGTERM and SIGHUP held back for the block: one that arrives is raised again after it (so the
    command's own handler still ends the run, with the set in place). Off the main thread, a no-op."""
    numbers = [getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name)]
    arrived: list[int] = []
    try:
        previous = {number: signal.signal(number, lambda signum, frame: arrived.append(signum))
                    for number in numbers}
    except ValueError:  # not the main thread: signals cannot be handled here
        yield
        return
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)
        for number in dict.fromkeys(arrived):
            signal.raise_signal(number)
