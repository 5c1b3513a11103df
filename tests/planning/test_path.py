"""plan_path: A* on the grid, smoothed through free space; bad ends and unreachable goals say what blocks."""

from __future__ import annotations

import numpy as np
import pyastar2d
import pytest
import trimesh

from bim2rdt.planning import KeepOut, OccupancyGrid, PlanningError, path_length, plan_path, worker_keepouts
from bim2rdt.sim.site import yaw_pose
from bim2rdt.twin import ElementStatus

from path_checks import samples_free, segments_through, wall_mesh

DOCK, EAST_ROOM = (1.0, 1.0), (16.0, 10.0)


class Seen:
    def __init__(self, pose, mesh):
        self.pose, self.mesh, self.status = pose, mesh, ElementStatus.NEW


def test_the_path_to_the_east_room_goes_through_the_door_and_never_through_a_wall(site_grid, site_model):
    path = plan_path(site_grid, DOCK, EAST_ROOM)
    assert np.allclose(path[0], DOCK) and np.allclose(path[-1], EAST_ROOM)
    assert segments_through(wall_mesh(site_model), path) == []
    assert samples_free(site_grid, path)
    crossing = [(a, b) for a, b in zip(path[:-1], path[1:]) if (a[0] - 12.0) * (b[0] - 12.0) < 0]
    assert len(crossing) == 1
    (a, b), = crossing
    y_at_wall = a[1] + (12.0 - a[0]) * (b[1] - a[1]) / (b[0] - a[0])
    assert 8.0 + 0.35 <= y_at_wall <= 9.0 - 0.35 + 0.05     # the 1 m door, less the robot's radius


def test_the_smoothed_path_is_no_longer_than_the_grid_path_and_straight_where_it_can_be(site_grid):
    path = plan_path(site_grid, DOCK, EAST_ROOM)
    cells = pyastar2d.astar_path(site_grid.cost, site_grid.frame.cell_of(DOCK), site_grid.frame.cell_of(EAST_ROOM),
                                 allow_diagonal=True)
    grid_length = path_length(site_grid.frame.centres(cells[:, 0], cells[:, 1]))
    assert path_length(path) < grid_length and len(path) < 10
    straight = plan_path(site_grid, (2.0, 8.0), (9.0, 8.0))
    assert len(straight) == 2 and path_length(straight) == pytest.approx(7.0)


def test_the_robot_replans_around_a_new_object_dropped_on_its_path(site_grid):
    before = plan_path(site_grid, DOCK, EAST_ROOM)
    middle = (before[1] + before[2]) / 2
    drum = trimesh.creation.cylinder(radius=0.4, height=0.9, transform=trimesh.transformations.translation_matrix((0, 0, 0.45)))
    grid = site_grid.with_obstacles({"drum": Seen(yaw_pose(*middle, 0.0, 0.0), drum)})
    assert not samples_free(grid, before)
    after = plan_path(grid, DOCK, EAST_ROOM)
    assert samples_free(grid, after) and path_length(after) > path_length(before)


def test_a_start_inside_a_wall_names_the_wall(site_grid):
    with pytest.raises(PlanningError, match=r"^start \(10\.00, 0\.15\) is inside Exterior Wall - South \(IfcWall\)$"):
        plan_path(site_grid, (10.0, 0.15), EAST_ROOM)


def test_a_goal_too_close_to_a_column_says_the_robot_does_not_fit(site_grid):
    with pytest.raises(PlanningError, match=r"goal \(6\.45, 5\.00\) is within 0\.35 m \(the robot's radius\) of "
                                            r"Column C11 \(IfcColumn\)"):
        plan_path(site_grid, DOCK, (6.45, 5.0))


@pytest.mark.parametrize("goal, message", [((50.0, 50.0), r"goal \(50\.00, 50\.00\) is outside the grid"),
                                           ((1.0,), "goal must be a finite"), ("here", "goal must be"),
                                           ((np.nan, 1.0), "goal must be a finite"),
                                           ((1e308, 0.0), r"goal \(1e\+308, 0\.00\) is outside the grid"),
                                           ((-1e308, -1e308), "goal .* is outside the grid")])
def test_bad_ends_are_one_line_errors(site_grid, goal, message):
    with pytest.raises(PlanningError, match=message) as error:
        plan_path(site_grid, DOCK, goal)
    assert "\n" not in str(error.value)


def test_a_closed_door_is_named_as_what_blocks_the_room_behind_it(site_model):
    grid = OccupancyGrid.from_bim(site_model, doors="closed")
    with pytest.raises(PlanningError, match=r"no path from \(1\.00, 1\.00\) to \(16\.00, 10\.00\): blocked by "
                                            r"Door D01 \(IfcDoor\); without it the way is free"):
        plan_path(grid, DOCK, EAST_ROOM)


def test_a_keepout_zone_across_the_doorway_is_named(site_grid):
    grid = site_grid.with_zones([KeepOut.polygon("Hot works", [(11.0, 7.5), (13.0, 7.5), (13.0, 9.5), (11.0, 9.5)])])
    with pytest.raises(PlanningError, match=r"blocked by Hot works \(keep-out zone\)"):
        plan_path(grid, DOCK, EAST_ROOM)


def test_a_grinding_worker_in_the_doorway_is_named(site_grid):
    grid = site_grid.with_zones(worker_keepouts([("worker 2", (11.0, 8.5), True)]))
    with pytest.raises(PlanningError, match=r"blocked by worker 2 \(worker\)"):
        plan_path(grid, DOCK, EAST_ROOM)
    assert len(plan_path(site_grid.with_zones(worker_keepouts([("worker 2", (9.0, 11.0), False)])), DOCK, EAST_ROOM))


def test_a_goal_walled_in_says_what_closes_the_way():
    occupied = np.zeros((100, 100), bool)
    occupied[40:60, 40] = occupied[40:60, 59] = occupied[40, 40:60] = occupied[59, 40:60] = True
    grid = OccupancyGrid.from_occupancy(occupied, 0.1, robot_radius=0.2, name="fence")
    with pytest.raises(PlanningError, match=r"the way is closed by fence \(element\)"):
        plan_path(grid, (1.0, 1.0), (5.0, 5.0))


def test_from_occupancy_checks_its_array():
    with pytest.raises(PlanningError, match="non-empty 2-D array"):
        OccupancyGrid.from_occupancy(np.zeros(5, bool), 0.1)
