"""Errors of the perception front end."""

from __future__ import annotations

from bim2rdt.errors import Bim2RdtError


class PerceptionError(Bim2RdtError):
    """A frame or detection the front end cannot use; the message says which field and why, in one line."""
