"""The append-only audit log of reveals: who saw (or tried to see) which worker's identity or raw sensor data,
when, why, and what came of it.

One JSON object per line, appended with ``O_APPEND``. ``append`` returns only once the whole line is written and
fsynced; a short write, a full disk or a failed sync is an ``AuditError``, and the API then answers 503 without
revealing anything. A record cut by such a failure stays on disk as it is (nothing in bim2rdt rewrites, truncates
or removes the log): the next record starts on a line of its own, and ``entries`` reports the cut line as a
``damaged`` entry in its place instead of failing. The log errs towards saying more was seen, never less: a record
whose bytes all landed before its sync failed reads as whole, though its reveal was answered 503.

The file is created 0600 (its folder's entry synced too). The OS calls go through ``write`` and ``sync`` (default
``os.write`` and ``os.fsync``), so a test can stand in a disk that fails.
"""

from __future__ import annotations

import json
import os
import threading
import time
from collections.abc import Callable
from pathlib import Path

from bim2rdt.errors import Bim2RdtError

DAMAGED = "damaged"
"""The action of an entry standing for a line of the log that is not a whole record."""
TEXT_KEPT = 200
"""Characters of a damaged line shown in its entry."""


class AuditError(Bim2RdtError):
    """A record could not be made durable: whatever it was to audit must not happen."""


class AuditLog:
    """Appends records to ``path`` (created with its folder); ``entries()`` reads them back, oldest first."""

    def __init__(self, path: Path, *, write: Callable[[int, bytes], int] = os.write,
                 sync: Callable[[int], None] = os.fsync):
        self.path = Path(path)
        self._write, self._sync = write, sync
        self._lock = threading.Lock()
        self.path.parent.mkdir(parents=True, exist_ok=True)
        created = not self.path.exists()
        os.close(os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o600))
        if created:
            _sync_folder(self.path.parent)

    def append(self, who: str, role: str, action: str, subject: str, why: str, detail: dict | None = None,
               outcome: str = "revealed") -> dict:
        """Write one record (``at``: UTC epoch seconds) and return it once it is durably on disk; AuditError
        (nothing else) when it cannot be."""
        record = {"at": time.time(), "who": who, "role": role, "action": action, "subject": subject, "why": why,
                  "outcome": outcome, "detail": detail or {}}
        line = (json.dumps(record, sort_keys=True) + "\n").encode("utf-8")
        with self._lock:
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_APPEND)
            except OSError as error:
                raise AuditError(f"the audit log {self.path} cannot be written: {error.strerror or error}") from None
            try:
                self._append_line(fd, line)
            finally:
                os.close(fd)
        return record

    def entries(self) -> list[dict]:
        """Every record, oldest first; a line that is not a whole record (a torn write) is a ``damaged`` entry in
        its place: ``detail`` = {line (1-based), bytes, text (its first characters)}, ``at`` None."""
        with self._lock:
            data = self.path.read_bytes()
        lines = data.split(b"\n")
        out = []
        for number, raw in enumerate(lines, start=1):
            if not raw.strip():
                continue
            whole = number < len(lines)  # the last piece has no newline: its write never finished
            record = _record(raw) if whole else None
            out.append(record if record is not None else _damaged(number, raw))
        return out

    def _append_line(self, fd: int, line: bytes) -> None:
        try:
            if not _ends_a_line(fd):
                line = b"\n" + line  # a torn record before: this one starts on a line of its own
            written = 0
            while written < len(line):
                count = self._write(fd, line[written:])
                if count <= 0:
                    raise OSError(0, "the disk took no bytes")
                written += count
            self._sync(fd)
        except OSError as error:
            raise AuditError(f"the audit log {self.path} cannot be written: {error.strerror or error}") from None


def _ends_a_line(fd: int) -> bool:
    size = os.fstat(fd).st_size
    return size == 0 or os.pread(fd, 1, size - 1) == b"\n"


def _record(raw: bytes) -> dict | None:
    try:
        record = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError):
        return None
    if not isinstance(record, dict) or not isinstance(record.get("at"), int | float):
        return None
    record.setdefault("outcome", "revealed")  # logs written before outcomes were recorded
    return record


def _damaged(number: int, raw: bytes) -> dict:
    text = raw.decode("utf-8", "replace")[:TEXT_KEPT]
    return {"at": None, "who": "", "role": "", "action": DAMAGED, "subject": "",
            "why": f"line {number} of the audit log is not a whole record ({len(raw)} bytes): a write cut short",
            "outcome": DAMAGED, "detail": {"line": number, "bytes": len(raw), "text": text}}


def _sync_folder(folder: Path) -> None:
    fd = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
