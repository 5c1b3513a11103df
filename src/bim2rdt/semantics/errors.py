"""The typed error of the semantics domain."""

from __future__ import annotations

from bim2rdt.errors import Bim2RdtError


class SemanticsError(Bim2RdtError):
    """Bad input to the semantics step (an out-of-range prior, a broken knowledge-base table, a missing extra)."""
