"""Workers appear under pseudonyms; only the safety role may turn a pseudonym back into a name.

A pseudonym is a keyed hash (HMAC-SHA256 with the site secret, ``Settings.hav.site_secret``) of the worker id:
stable across days and restarts, not reversible without the secret, different on every site. The identity map
(pseudonym -> worker id) lives in its own SQLite file in a private folder (mode 0700, file 0600), apart from
the exposure store, and :meth:`IdentityMap.real_name` refuses any role but ``safety``.
"""

from __future__ import annotations

import hashlib
import hmac
import os
import sqlite3
from pathlib import Path

from bim2rdt.safety.errors import AccessDenied, HavError

SAFETY_ROLE = "safety"


def pseudonym(worker_id: str, secret: str) -> str:
    """The worker's pseudonym on this site: 'w-' + 16 hex digits of HMAC-SHA256(secret, worker id)."""
    if not worker_id:
        raise HavError("worker id must not be empty")
    return "w-" + hmac.new(secret.encode(), worker_id.encode(), hashlib.sha256).hexdigest()[:16]


class IdentityMap:
    """The pseudonym -> worker id map, readable only by the safety role."""

    def __init__(self, path: Path | None, role: str):
        """``path`` None keeps the map in memory (a throw-away monitor, e.g. analysing a file)."""
        self.path, self.role = (Path(path) if path is not None else None), role
        if self.path is None:
            self._db = sqlite3.connect(":memory:", check_same_thread=False)
        else:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            os.chmod(self.path.parent, 0o700)
            self._db = sqlite3.connect(self.path, check_same_thread=False)
            os.chmod(self.path, 0o600)
        self._db.execute("CREATE TABLE IF NOT EXISTS identity (pseudonym TEXT PRIMARY KEY, worker TEXT NOT NULL)")
        self._db.commit()

    def remember(self, pseudonym_: str, worker_id: str) -> None:
        """Record who is behind a pseudonym (any role may add; the monitor does when a session starts)."""
        self._db.execute("INSERT OR REPLACE INTO identity VALUES (?, ?)", (pseudonym_, worker_id))
        self._db.commit()

    def real_name(self, pseudonym_: str) -> str | None:
        """The worker id behind ``pseudonym_``: safety role only (AccessDenied otherwise)."""
        if self.role != SAFETY_ROLE:
            raise AccessDenied(f"role {self.role!r} may not read the identity map (only {SAFETY_ROLE!r})")
        row = self._db.execute("SELECT worker FROM identity WHERE pseudonym = ?", (pseudonym_,)).fetchone()
        return row[0] if row else None

    def close(self) -> None:
        self._db.close()
