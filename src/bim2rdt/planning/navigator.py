"""The robot walking its planned paths on a clock, replanning when the world changes under its feet.

The grid the robot plans on is the BIM's, with the objects observed so far (``observe``) and the keep-out zones
in force at the moment (``zones_at(t)``, which change at ``zone_changes`` times: a worker starts or stops their
tool). Whenever either changes, the rest of the path being walked is checked; if a leg now crosses a blocked
cell the robot replans from where it stands, and the log says when, where and what blocked it. If a zone
switches on around the robot, it first steps out by the shortest way.

Time is in seconds on the caller's clock (the shift's, so zone changes line up with the HAV monitor's events);
the robot walks at ``speed`` m/s.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from bim2rdt.planning.errors import PlanningError
from bim2rdt.planning.grid import OccupancyGrid
from bim2rdt.planning.path import path_length, plan_path
from bim2rdt.planning.sight import first_blocked_leg

WALKING_SPEED = 0.7
"""A quadruped's cautious walking speed on site, m/s."""
ESCAPE_DISTANCE = 4.0
"""Farthest the robot looks for free ground when a zone switches on around it, m."""


@dataclass(frozen=True)
class Leg:
    """A stretch walked: ``path`` (N, 2) world metres, from ``start_time`` to ``end_time`` (s); ``replanned`` says
    why it was planned anew (None for a stretch of the path first planned)."""

    path: np.ndarray
    start_time: float
    end_time: float
    replanned: str | None = None


@dataclass(frozen=True)
class Replan:
    """When (s) and where (x, y) the robot replanned, and why (what blocked the path it was on)."""

    time: float
    xy: tuple[float, float]
    reason: str


@dataclass
class Navigator:
    """Walks planned paths on ``base`` (the BIM's grid) plus what was observed and the zones of the moment."""

    base: OccupancyGrid
    position: np.ndarray
    time: float = 0.0
    speed: float = WALKING_SPEED
    zones_at: Callable[[float], Sequence] = lambda t: ()
    zone_changes: Sequence[float] = ()
    legs: list[Leg] = field(default_factory=list)
    replans: list[Replan] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.position = np.asarray(self.position, float)
        self._observed: Mapping | Iterable = {}
        self._zone_time = self.time
        self.grid = self._current_grid()

    def observe(self, twin_state: Mapping | Iterable) -> None:
        """Take the objects seen so far into the map.

        Args:
            twin_state: The twin's state (see ``OccupancyGrid.with_obstacles``).
        """
        self._observed = twin_state
        self.grid = self._current_grid()

    def changes_within(self, seconds: float) -> list[float]:
        """The times the keep-out zones change soon.

        Args:
            seconds: How far ahead to look, seconds.

        Returns:
            The change times (seconds, on the navigator's clock) within that window, earliest first.
        """
        return sorted(t for t in self.zone_changes if self.time < t <= self.time + seconds)

    def wait(self, seconds: float) -> None:
        """Stand still (capturing at a station); a zone that switches on around the robot meanwhile makes it
        step out at once.

        Args:
            seconds: How long to stand, seconds.

        Raises:
            PlanningError: A zone switched on around the robot and no free place is in reach.
        """
        end = self.time + float(seconds)
        change = self._next_change()
        while change is not None and change <= end:
            self.time = max(self.time, change)
            self._zone_time = change
            self.grid = self._current_grid()
            self._step_out([self.position.copy()], "a keep-out zone switched on around the robot")
            change = self._next_change()
        self.time = max(self.time, end)

    def go(self, goal_xy: np.ndarray | tuple[float, float], path: np.ndarray | None = None) -> np.ndarray:
        """Walk to a goal, replanning as the world changes (``legs`` and ``replans`` log it).

        Args:
            goal_xy: World (x, y) of the goal, metres.
            path: (N,2) world waypoints to follow, metres; None plans one now.

        Returns:
            (M,2) the path walked, world metres.

        Raises:
            PlanningError: No path leads there now (the robot stays where it got to).
        """
        self._catch_up()
        goal = np.asarray(goal_xy, float)
        walked = [self.position.copy()]
        self._step_out(walked, "a keep-out zone switched on around the robot")
        planned, why = self._checked(path, goal)
        while True:
            change = self._next_change()
            arrival = self.time + path_length(np.vstack([self.position, planned[1:]])) / self.speed
            if change is None or change >= arrival:
                self._walk(np.vstack([self.position, planned[1:]]), arrival, why, walked)
                return np.array(walked)
            self._walk_until(np.vstack([self.position, planned[1:]]), change, why, walked)
            planned = np.vstack([self.position, _remaining(planned, self.position)])
            self._zone_time = change
            self.grid = self._current_grid()
            reason = self._blocked_reason(planned)
            if reason is not None:
                self._step_out(walked, reason)
                planned, why = self._plan(goal, reason), reason

    # ---- internals ---------------------------------------------------------------------------------------------

    def _catch_up(self) -> None:
        change = self._next_change()
        if change is not None and change <= self.time:
            self._zone_time = self.time
            self.grid = self._current_grid()

    def _current_grid(self) -> OccupancyGrid:
        return self.base.with_obstacles(self._observed).with_zones(self.zones_at(self._zone_time))

    def _next_change(self) -> float | None:
        later = [t for t in self.zone_changes if t > self._zone_time]
        return min(later) if later else None

    def _checked(self, path: np.ndarray | None, goal: np.ndarray) -> tuple[np.ndarray, str | None]:
        """The given path, or a new one if there is none, it does not start here, or the grid now blocks it
        (then also why)."""
        if path is None:
            return self._plan(goal, None), None
        if not np.allclose(np.asarray(path, float)[0], self.position):
            why = "the planned leg started elsewhere (the stop before it moved)"
            return self._plan(goal, why), why
        reason = self._blocked_reason(np.asarray(path, float))
        return (np.asarray(path, float), None) if reason is None else (self._plan(goal, reason), reason)

    def _plan(self, goal: np.ndarray, reason: str | None) -> np.ndarray:
        path = plan_path(self.grid, self.position, goal)
        if reason is not None:
            self.replans.append(Replan(self.time, (float(self.position[0]), float(self.position[1])), reason))
        return path

    def _blocked_reason(self, path: np.ndarray) -> str | None:
        """What now blocks ``path`` (a label from the grid), or None if it is still free."""
        leg = first_blocked_leg(self.grid, path)
        if leg is None:
            return None
        a, b = path[leg], path[leg + 1]
        for t in np.linspace(0.0, 1.0, max(int(np.linalg.norm(b - a) / (self.grid.resolution / 2)), 1) + 1):
            point = a + t * (b - a)
            if not self.grid.is_free(point):
                blockers = self.grid.blockers_at(point)
                return f"the path is blocked by {blockers[0][0].label}" if blockers else "the path left the grid"
        return "the path is blocked"

    def _step_out(self, walked: list, reason: str) -> None:
        """If a zone switched on around the robot, walk straight to the nearest free ground."""
        if self.grid.is_free(self.position) or not self.grid.frame.contains(self.grid.frame.cell_of(self.position)):
            return
        free = self.grid.nearest_free(self.position, ESCAPE_DISTANCE)
        if free is None:
            raise PlanningError(f"the robot at ({self.position[0]:.2f}, {self.position[1]:.2f}) is trapped: {reason}")
        blockers = self.grid.blockers_at(self.position)
        reason = f"{blockers[0][0].label} closed in around the robot" if blockers else reason
        self.replans.append(Replan(self.time, (float(self.position[0]), float(self.position[1])),
                                   f"stepped out: {reason}"))
        self._walk(np.array([self.position, free]), self.time + np.linalg.norm(free - self.position) / self.speed,
                   f"stepped out: {reason}", walked)

    def _walk(self, path: np.ndarray, arrival: float, reason: str | None, walked: list) -> None:
        self.legs.append(Leg(np.array(path, float), self.time, arrival, reason))
        walked.extend(np.asarray(path, float)[1:])
        self.position, self.time = np.asarray(path[-1], float).copy(), arrival

    def _walk_until(self, path: np.ndarray, when: float, reason: str | None, walked: list) -> None:
        """Walk along ``path`` until time ``when`` (before its end)."""
        done = _along(path, (when - self.time) * self.speed)
        self._walk(done, when, reason, walked)


def _along(path: np.ndarray, distance: float) -> np.ndarray:
    """The first ``distance`` metres of ``path``, as a path."""
    out, left = [path[0]], distance
    for a, b in zip(path[:-1], path[1:]):
        step = float(np.linalg.norm(b - a))
        if step >= left:
            out.append(a + (b - a) * (left / step if step > 0 else 0.0))
            return np.array(out)
        out.append(b)
        left -= step
    return np.array(out)


def _remaining(path: np.ndarray, here: np.ndarray) -> np.ndarray:
    """The corners of ``path`` still ahead of ``here`` (a point on it)."""
    for k, (a, b) in enumerate(zip(path[:-1], path[1:])):
        ab = b - a
        t = float(np.dot(here - a, ab) / max(np.dot(ab, ab), 1e-12))
        if 0.0 <= t <= 1.0 and np.linalg.norm(a + t * ab - here) < 1e-6:
            return path[k + 1:]
    return path[-1:]
