"""Line of sight over the BIM's structure (walls occlude, site objects do not), and whether a path survived a change."""

from __future__ import annotations

import numpy as np
import trimesh

from bim2rdt.planning import OccupancyGrid, first_blocked_leg, line_of_sight, plan_path
from bim2rdt.sim.site import yaw_pose


def test_the_interior_wall_hides_the_east_room_except_through_the_open_door(site_grid, site_model):
    assert not line_of_sight(site_grid, (10.5, 8.5), (13.5, 10.5))
    assert line_of_sight(site_grid, (10.5, 8.5), (13.5, 8.5))
    assert not line_of_sight(OccupancyGrid.from_bim(site_model, doors="closed"), (10.5, 8.5), (13.5, 8.5))


def test_site_objects_do_not_hide_each_other_and_a_column_does(site_grid):
    assert line_of_sight(site_grid, (3.0, 0.8), (5.4, 2.0 + 1.2 * 1.0))   # past the cones
    assert not line_of_sight(site_grid, (6.0, 3.0), (6.0, 7.0))          # column C11 at (6, 5)


def test_an_object_against_a_wall_is_seen_from_the_room(site_grid):
    assert line_of_sight(site_grid, (5.0, 11.0), (5.0, 13.55))   # 0.15 m from the north wall's face


def test_first_blocked_leg_says_where_a_new_obstacle_cuts_the_path(site_grid):
    path = plan_path(site_grid, (1.0, 1.0), (16.0, 10.0))
    assert first_blocked_leg(site_grid, path) is None
    middle = (path[1] + path[2]) / 2

    class Drum:
        pose = yaw_pose(*middle, 0.0, 0.0)
        mesh = trimesh.creation.cylinder(radius=0.3, height=0.9)
        status = "new"

    assert first_blocked_leg(site_grid.with_obstacles({"drum": Drum()}), path) == 1
    assert first_blocked_leg(site_grid, np.array([(1.0, 1.0), (40.0, 1.0)])) == 0
