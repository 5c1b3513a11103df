"""Bearer tokens and roles.

Tokens are random (``new_token``: 256 bits), so a plain SHA-256 digest is what is stored and compared (as for API
tokens elsewhere: a slow password hash guards guessable secrets, and these are not guessable). A request carries
``Authorization: Bearer <token>``; the digest is compared with every configured one in constant time.

Roles are not a ladder: ``viewer`` reads the twin and exposure under pseudonyms; ``safety`` (the safety officer)
reads that too and may reveal identities and raw sensor windows; ``admin`` reads that too and the audit log of
those reveals, but may not reveal (who audits the reveals does not make them).
"""

from __future__ import annotations

import hashlib
import hmac
import secrets
from collections.abc import Iterable
from dataclasses import dataclass

VIEWER, SAFETY, ADMIN = "viewer", "safety", "admin"
READERS = frozenset({VIEWER, SAFETY, ADMIN})
"""Every role reads the twin, the exposure under pseudonyms and the events."""


@dataclass(frozen=True)
class Principal:
    """Who made a request: the token holder's ``name`` and ``role``."""

    name: str
    role: str


def new_token() -> str:
    """Make a fresh bearer token.

    Returns:
        43 URL-safe characters (256 random bits).
    """
    return secrets.token_urlsafe(32)


def token_digest(token: str) -> str:
    """What the settings store for a token, so a leaked settings file reveals no token.

    Args:
        token: The bearer token.

    Returns:
        Its SHA-256 hex digest.
    """
    return hashlib.sha256(token.encode("utf-8")).hexdigest()


class TokenBook:
    """The configured tokens, by digest; ``holder(token)`` is the Principal or None."""

    def __init__(self, entries: Iterable[tuple[str, str, str]]):
        self._entries = [(bytes.fromhex(digest), Principal(name, role)) for name, role, digest in entries]

    def holder(self, token: str | None) -> Principal | None:
        if not token:
            return None
        digest = hashlib.sha256(token.encode("utf-8", "replace")).digest()
        found = None
        for stored, principal in self._entries:  # no early exit: the time does not say which entry matched
            if hmac.compare_digest(stored, digest):
                found = principal
        return found

    def __len__(self) -> int:
        return len(self._entries)


def bearer(header: str | None) -> str | None:
    """The token of an ``Authorization: Bearer <token>`` header (None when absent or another scheme)."""
    if not header:
        return None
    scheme, _, token = header.partition(" ")
    return token.strip() or None if scheme.lower() == "bearer" else None
