"""The structure judge's one error type."""

from bim2rdt.errors import Bim2RdtError


class StructureError(Bim2RdtError):
    """Bad input to the structure judge (a view with bad points or pose, an unreadable structure.json)."""
