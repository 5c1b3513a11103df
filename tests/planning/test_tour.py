"""plan_tour: a tour ordered by the paths the robot walks, not by straight lines through walls."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.planning import OccupancyGrid, path_length, plan_tour

START = (10.8, 3.0)
EAST_ROOM, WEST = (13.5, 7.0), (5.9, 3.3)   # the east room is nearer in a straight line, but behind a wall


def test_the_tour_visits_what_is_nearer_by_path_first(site_grid):
    straight = [np.hypot(*np.subtract(goal, START)) for goal in (EAST_ROOM, WEST)]
    assert straight[0] < straight[1]
    tour = plan_tour(site_grid, START, [EAST_ROOM, WEST])
    assert tour.order == [1, 0] and tour.unreachable == {}
    assert np.allclose(tour.legs[0][0], START) and np.allclose(tour.legs[0][-1], WEST)
    assert np.allclose(tour.legs[1][0], WEST) and np.allclose(tour.legs[1][-1], EAST_ROOM)
    assert tour.length == pytest.approx(sum(path_length(leg) for leg in tour.legs))


def test_local_search_turns_back_first_where_nearest_first_would_walk_the_row_twice(site_grid):
    """From x = 5: nearest-first takes 6, 7, ... 10, then walks back to 3.9 (11.1 m); 3.9 first is 7.2 m."""
    goals = [(3.9, 8.0), (6.0, 8.0), (7.0, 8.0), (8.0, 8.0), (9.0, 8.0), (10.0, 8.0)]
    tour = plan_tour(site_grid, (5.0, 8.0), goals)
    assert tour.order == [0, 1, 2, 3, 4, 5]
    assert tour.length == pytest.approx(1.1 + 6.1, abs=0.01)


def test_an_unreachable_goal_is_left_out_with_the_reason(site_model):
    grid = OccupancyGrid.from_bim(site_model, doors="closed")
    tour = plan_tour(grid, START, [EAST_ROOM, WEST])
    assert tour.order == [1] and list(tour.unreachable) == [0]
    assert "blocked by Door D01 (IfcDoor)" in tour.unreachable[0]
