"""The order of a tour: visit goals by the length of the paths between them, not of straight lines.

Every pair's path is planned once (the matrix is symmetric, so n(n+1)/2 plans for n goals and the start), then
nearest-neighbour from the start, then 2-opt and relocation moves on the open tour, improve the order on those
lengths. A goal no path
reaches is left out with the planner's reason; the legs of the chosen order are the planned paths themselves.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bim2rdt.planning.errors import PlanningError
from bim2rdt.planning.grid import OccupancyGrid
from bim2rdt.planning.path import path_length, plan_path


@dataclass
class Tour:
    """``order``: goal indices in visiting order; ``legs``: the path (N, 2) world metres to each, from the start
    or the goal before; ``unreachable``: {goal index: why}."""

    order: list[int]
    legs: list[np.ndarray]
    unreachable: dict[int, str] = field(default_factory=dict)

    @property
    def length(self) -> float:
        """Metres walked over the whole tour."""
        return sum(path_length(leg) for leg in self.legs)


def plan_tour(grid: OccupancyGrid, start_xy: np.ndarray | tuple[float, float], goals_xy: np.ndarray) -> Tour:
    """Order goals for a tour from a start by planned path length (nearest first, then 2-opt and relocation
    until no move shortens it), with the planned path of every leg.

    Args:
        grid: The occupancy grid.
        start_xy: World (x, y) of the start, metres.
        goals_xy: (K,2) world goals, metres.

    Returns:
        The tour: the goals' order (indices into ``goals_xy``), one (N,2) path per leg, and {goal index: reason}
            for the goals the start cannot reach.
    """
    points = np.vstack([np.asarray(start_xy, float).reshape(1, 2), np.asarray(goals_xy, float).reshape(-1, 2)])
    paths, unreachable = _pair_paths(grid, points)
    reachable = [k for k in range(1, len(points)) if (0, k) in paths]
    lengths = {pair: path_length(path) for pair, path in paths.items()}
    order = _improve(_nearest_first(reachable, lengths), lengths)
    legs, here = [], 0
    for goal in order:
        leg = paths[(here, goal)] if here < goal else paths[(goal, here)][::-1]
        legs.append(leg)
        here = goal
    return Tour([k - 1 for k in order], legs, {k - 1: why for k, why in unreachable.items()})


def _pair_paths(grid: OccupancyGrid, points: np.ndarray) -> tuple[dict, dict]:
    """Paths for every pair (i < j) of points that the start reaches; {goal: reason} for those it does not."""
    paths, unreachable = {}, {}
    for goal in range(1, len(points)):
        try:
            paths[(0, goal)] = plan_path(grid, points[0], points[goal])
        except PlanningError as error:
            unreachable[goal] = str(error)
    reachable = [k for k in range(1, len(points)) if k not in unreachable]
    for i, first in enumerate(reachable):
        for second in reachable[i + 1:]:
            paths[(first, second)] = plan_path(grid, points[first], points[second])
    return paths, unreachable


def _cost(lengths: dict, a: int, b: int) -> float:
    return lengths[(a, b)] if a < b else lengths[(b, a)]


def _nearest_first(goals: list[int], lengths: dict) -> list[int]:
    order, here, left = [], 0, list(goals)
    while left:
        here = min(left, key=lambda goal: _cost(lengths, here, goal))
        order.append(here)
        left.remove(here)
    return order


def _improve(order: list[int], lengths: dict) -> list[int]:
    """Local search on the open tour (start fixed, end free) until no move shortens it: 2-opt (reverse a stretch)
    and relocation (move one goal elsewhere; 2-opt alone cannot turn back for a goal nearest-first left behind)."""
    best, best_length = list(order), _route_length(order, lengths)
    improved = True
    while improved:
        improved = False
        for candidate in _neighbours(best):
            length = _route_length(candidate, lengths)
            if length < best_length - 1e-9:
                best, best_length, improved = candidate, length, True
                break
    return best


def _neighbours(order: list[int]):
    for i in range(len(order)):
        for j in range(i + 1, len(order)):
            yield order[:i] + order[i:j + 1][::-1] + order[j + 1:]
        rest = order[:i] + order[i + 1:]
        for j in range(len(order)):
            if j != i:
                yield rest[:j] + [order[i]] + rest[j:]


def _route_length(order: list[int], lengths: dict) -> float:
    route = [0, *order]
    return sum(_cost(lengths, a, b) for a, b in zip(route[:-1], route[1:]))
