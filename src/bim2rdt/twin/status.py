"""The status of a BIM element in the twin, as the robot last saw it: :class:`ElementStatus` (defined with the
shared observation record, :mod:`bim2rdt.perception.observation`) and its colours."""

from __future__ import annotations

from bim2rdt.perception import ElementStatus

__all__ = ["STATUS_COLOURS", "ElementStatus"]


STATUS_COLOURS = {ElementStatus.NOT_OBSERVED: "0.75", ElementStatus.AS_PLANNED: "tab:green",
                  ElementStatus.DEVIATING: "tab:orange", ElementStatus.MISSING: "tab:purple",
                  ElementStatus.NEW: "tab:red", ElementStatus.UNVERIFIED: "tab:grey",
                  ElementStatus.NOT_BUILT: "tab:brown"}
"""One matplotlib colour per status, shared by snapshots, plan maps and reports."""
