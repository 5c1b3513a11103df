"""The planning package's error: one line naming what is wrong (a blocked start, no path and what blocks it)."""

from bim2rdt.errors import Bim2RdtError


class PlanningError(Bim2RdtError):
    """Bad input to the planner (resolution 0, a storey without a slab, a start inside a wall) or no path."""
