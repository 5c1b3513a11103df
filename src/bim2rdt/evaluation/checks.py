"""A benchmark's verdict on one of its targets (an issue's speed or accuracy goal), checked on a finished run.

Not to be confused with the mission's :class:`~bim2rdt.mission.Target` (a BIM element the robot is sent to see)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class TargetCheck:
    """The target's ``name`` (what it asks: "fused worst station <= 5 cm"), whether the run ``passed`` it, and
    the ``detail``: the figure that decided it."""

    name: str
    passed: bool
    detail: str
