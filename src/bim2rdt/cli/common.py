"""Helpers shared by the CLI modules: --out folder checks, JSON output and rich tables. No command lives here."""

from __future__ import annotations

import json
import re
import sys
import tempfile
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.table import Table

console = Console(width=None if sys.stdout.isatty() else 140)
"""Rich console; piped output (CI logs, files) gets 140 columns instead of rich's 80 so tables do not fold."""


def out_path(value: str | Path) -> Path:
    """Parser of output path options: an empty string (an unset shell variable) is refused, where a Path would
    silently become the current folder."""
    if isinstance(value, Path):
        return value
    if not value.strip():
        raise typer.BadParameter("an empty path")
    return Path(value)


def writable_folder(path: Path) -> Path:
    """Callback of ``--out`` folder options: create the folder and probe it with a temporary file now, so a path
    that cannot take files fails in one line before a run of minutes, not with a traceback after it."""
    if path.exists() and not path.is_dir():
        raise typer.BadParameter(f"cannot write into {path}: it is a file, not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=path).close()
    except OSError as error:
        raise typer.BadParameter(f"cannot write into {path}: {error.strerror or error}") from error
    return path


def print_json(payload: Any) -> None:
    """Machine output for --json: one JSON document on stdout."""
    print(json.dumps(payload, indent=2, default=_json_default))


def print_table(title: str, columns: Sequence[str], rows: Sequence[Sequence[Any]]) -> None:
    """A rich table; floats are shown with 4 significant digits."""
    table = Table(title=title)
    cells = [[_cell(value) for value in row] for row in rows]
    for index, column in enumerate(columns):
        ids = [row[index] for row in cells if index < len(row) and IFC_GUID.fullmatch(row[index])]
        if ids:  # an identifier is copied into the next command: never cut, never wrapped
            table.add_column(column, no_wrap=True, min_width=max(map(len, ids)), overflow="fold")
        else:
            table.add_column(column)
    for row in cells:
        table.add_row(*row)
    console.print(table)


IFC_GUID = re.compile(r"[0-9A-Za-z_$]{22}")
"""An IFC GlobalId: 22 characters of IFC's base-64 alphabet."""


def _cell(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def _json_default(value: Any) -> Any:
    if hasattr(value, "tolist"):
        return value.tolist()
    if hasattr(value, "model_dump"):
        return value.model_dump()
    return str(value)


def sample_file(name: str) -> Path:
    """A shared sample IFC file by name: $BIM2RDT_SAMPLES, else ../shared/data/ifc beside the checkout. A one-line
    error when it is absent."""
    from bim2rdt.bim import BimError
    from bim2rdt.config import get_settings

    folder = get_settings().samples or Path(__file__).resolve().parents[4].parent / "shared" / "data" / "ifc"
    path = Path(folder) / name
    if not path.is_file():
        raise BimError(f"{path}: sample file absent (set BIM2RDT_SAMPLES or pass --file)")
    return path


STOP_SIGNALS = ("SIGINT", "SIGTERM", "SIGHUP")
"""Ctrl-C, a supervisor's stop (systemd, docker, kill) and a closed terminal: each ends a long-running command the
same way, with its summary and exit 0."""


@contextmanager
def stop_requested() -> Iterator[threading.Event]:
    """An event that ``STOP_SIGNALS`` set, for a command's loop to end at a point of its choosing (never inside a
    commit, as an exception raised from a signal handler could); the previous handlers are restored after."""
    import signal

    stop = threading.Event()
    numbers = [getattr(signal, name) for name in STOP_SIGNALS if hasattr(signal, name)]
    previous = {number: signal.signal(number, lambda signum, frame: stop.set()) for number in numbers}
    try:
        yield stop
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)


INCOMPLETE_MARKER = "INCOMPLETE.txt"
"""Left in a run's output folder when the run failed or was interrupted: what is there is partial."""

_run_folders: list[tuple[Path, bool]] = []
"""The output folders of this process's command, each with whether the command created it."""


def run_folder(path: Path) -> Path:
    """Callback of ``--out`` options whose folder holds a run's product (``demo``, benchmarks, exports): checked as
    :func:`writable_folder`, and remembered, so a run that fails or is interrupted leaves no empty folder it made
    behind and marks a folder with partial output (:func:`close_run_folders`). A marker from an earlier run goes:
    this run writes its own verdict."""
    created = not path.exists()
    writable_folder(path)
    (path / INCOMPLETE_MARKER).unlink(missing_ok=True)
    _run_folders.append((path, created, True))
    return path


def set_folder(path: Path) -> Path:
    """Callback of ``--out`` options whose run moves its files in as one set at its end (``verify``: an
    interrupted run leaves the earlier set whole): checked as :func:`writable_folder`, and a folder this run made is
    removed if it is still empty after a failure; never marked incomplete (the set it holds is complete)."""
    created = not path.exists()
    writable_folder(path)
    _run_folders.append((path, created, False))
    return path


def close_run_folders(reason: str) -> list[Path]:
    """After a failed or interrupted run: remove the empty folders it created, mark the others incomplete with
    ``reason``; returns the folders that hold partial output."""
    import datetime

    partial = []
    for path, created, marks in _run_folders:
        try:
            if created and path.is_dir() and not any(path.iterdir()):
                path.rmdir()
                continue
            if path.is_dir() and marks:
                stamp = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
                (path / INCOMPLETE_MARKER).write_text(f"incomplete: the run {reason} at {stamp}; the files here "
                                                      "are partial\n", encoding="utf-8")
                partial.append(path)
        except OSError:  # a folder we cannot tidy (a full disk, a removed mount): say nothing more than the error
            partial.append(path)
    _run_folders.clear()
    return partial
