"""The typed error of the BIM layer."""

from __future__ import annotations

from bim2rdt.errors import Bim2RdtError


class BimError(Bim2RdtError):
    """An IFC file cannot be read or written; the message is one line naming the file and the reason."""
