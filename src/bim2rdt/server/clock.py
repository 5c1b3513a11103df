"""The clock the dashboard shows: the time of the sources it serves (wall time, or a demo's simulated day).

A demo's simulated sources run on one simulated clock: it starts at ``origin_s`` (UTC s) when the wall clock reads
``wall_origin_s`` and runs ``speed`` times as fast. Real sources run on the wall clock (``speed`` 1, origin now).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field


@dataclass(frozen=True)
class SourceClock:
    """UTC seconds of the served sources: ``origin_s + speed * (wall now - wall_origin_s)``."""

    origin_s: float = field(default_factory=time.time)
    speed: float = 1.0
    wall_origin_s: float = field(default_factory=time.time)

    def now(self) -> float:
        return self.origin_s + self.speed * (time.time() - self.wall_origin_s)

    def as_dict(self) -> dict:
        """What /api/clock answers: the sources' time now and its speed (the page runs it on from there)."""
        return {"now": self.now(), "speed": self.speed, "simulated": self.speed != 1.0
                or abs(self.origin_s - self.wall_origin_s) > 1.0}


WALL_CLOCK = SourceClock(origin_s=0.0, speed=1.0, wall_origin_s=0.0)
"""The wall clock itself (real wearables and robots)."""

__all__ = ["SourceClock", "WALL_CLOCK"]
