"""The status of a BIM element in the twin, as the robot last saw it."""

from __future__ import annotations

from enum import Enum


class ElementStatus(str, Enum):
    """What the robot's evidence says about one element against the BIM (the value is what reports print).

    ``DEVIATING`` is out of tolerance (for a site object: moved or turned; for a column: out of plumb or off its
    grid line); ``MISSING`` is its place seen empty; ``NEW`` is an object the BIM does not have;
    ``UNVERIFIED`` is seen, but the fit is too poor (or the view too weak) to judge."""

    NOT_OBSERVED = "not observed"
    AS_PLANNED = "as planned"
    DEVIATING = "deviating"
    MISSING = "missing"
    NEW = "new"
    UNVERIFIED = "unverified"

    def __str__(self) -> str:
        return self.value


STATUS_COLOURS = {ElementStatus.NOT_OBSERVED: "0.75", ElementStatus.AS_PLANNED: "tab:green",
                  ElementStatus.DEVIATING: "tab:orange", ElementStatus.MISSING: "tab:purple",
                  ElementStatus.NEW: "tab:red", ElementStatus.UNVERIFIED: "tab:grey"}
"""One matplotlib colour per status, shared by snapshots, plan maps and reports."""
