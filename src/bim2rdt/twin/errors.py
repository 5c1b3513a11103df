"""The typed error of the twin."""

from __future__ import annotations

from bim2rdt.errors import Bim2RdtError


class TwinError(Bim2RdtError):
    """The twin cannot be opened, recorded into or exported; the message is one line (never a password)."""
