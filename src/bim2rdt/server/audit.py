"""The append-only audit log of reveals: who saw which worker's identity or raw sensor data, when and why.

One JSON object per line, appended with ``O_APPEND`` and fsynced before the reveal is answered, so a reveal is
never served without its record (if the record cannot be written, the request fails). The file is created 0600;
nothing in bim2rdt rewrites or truncates it. An admin reads it through the API.
"""

from __future__ import annotations

import json
import os
import threading
import time
from pathlib import Path


class AuditLog:
    """Appends records to ``path`` (created with its folder); ``entries()`` reads them back, oldest first."""

    def __init__(self, path: Path):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._lock = threading.Lock()
        os.close(os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o600))

    def append(self, who: str, role: str, action: str, subject: str, why: str, detail: dict | None = None) -> dict:
        """Write one record (``at``: UTC epoch seconds) and return it once it is on disk."""
        record = {"at": time.time(), "who": who, "role": role, "action": action, "subject": subject, "why": why,
                  "detail": detail or {}}
        line = (json.dumps(record, sort_keys=True) + "\n").encode("utf-8")
        with self._lock:
            fd = os.open(self.path, os.O_WRONLY | os.O_APPEND)
            try:
                os.write(fd, line)
                os.fsync(fd)
            finally:
                os.close(fd)
        return record

    def entries(self) -> list[dict]:
        with self._lock, open(self.path, encoding="utf-8") as handle:
            return [json.loads(line) for line in handle if line.strip()]
