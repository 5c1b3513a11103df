"""The navigator walks planned paths on a clock and replans when objects or workers' zones block them."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from bim2rdt.planning import KeepOut, Navigator, PlanningError, path_length, plan_path, worker_keepouts
from bim2rdt.sim.site import yaw_pose

from path_checks import samples_free

DOCK, EAST_ROOM = np.array([1.0, 1.0]), np.array([16.0, 10.0])


class Drum:
    def __init__(self, xy):
        self.pose = yaw_pose(*xy, 0.0, 0.0)
        self.mesh = trimesh.creation.cylinder(radius=0.3, height=0.9,
                                              transform=trimesh.transformations.translation_matrix((0, 0, 0.45)))
        self.status = "new"
        self.family = "Steel_Drum_55gal"


def test_with_nothing_changing_the_robot_walks_its_plan_at_its_speed(site_grid):
    robot = Navigator(site_grid, DOCK, time=100.0, speed=0.5)
    path = plan_path(site_grid, DOCK, EAST_ROOM)
    walked = robot.go(EAST_ROOM, path)
    assert np.allclose(walked, path) and robot.replans == []
    assert robot.time == pytest.approx(100.0 + path_length(path) / 0.5)
    assert np.allclose(robot.position, EAST_ROOM) and len(robot.legs) == 1


def test_a_newly_observed_object_on_the_planned_path_makes_the_robot_replan_around_it(site_grid):
    path = plan_path(site_grid, DOCK, EAST_ROOM)
    robot = Navigator(site_grid, DOCK)
    robot.observe({"drum": Drum((path[1] + path[2]) / 2)})
    walked = robot.go(EAST_ROOM, path)
    assert [r.reason for r in robot.replans] == ["the path is blocked by Steel_Drum_55gal (observed object)"]
    assert samples_free(robot.grid, walked) and not samples_free(robot.grid, path)
    assert robot.legs[0].replanned == robot.replans[0].reason


def test_a_worker_starting_to_grind_ahead_stops_the_robot_and_it_replans_around_their_zone(site_grid):
    path = plan_path(site_grid, DOCK, EAST_ROOM)
    longest = int(np.argmax(np.linalg.norm(np.diff(path, axis=0), axis=1)))
    worker_xy = tuple(path[longest] + 0.6 * (path[longest + 1] - path[longest]))
    start_grinding = 10.0

    def zones_at(t):   # the worker walks in and starts grinding at 10 s
        return worker_keepouts([("worker-001", worker_xy, True)], live_radius=1.5) if t >= start_grinding else []

    robot = Navigator(site_grid, DOCK, zones_at=zones_at, zone_changes=[start_grinding])
    walked = robot.go(EAST_ROOM, path)
    assert len(robot.replans) == 1 and robot.replans[0].time == pytest.approx(start_grinding)
    assert robot.replans[0].reason == "the path is blocked by worker-001 (worker)"
    before, after = robot.legs
    assert before.replanned is None and before.end_time == pytest.approx(start_grinding)
    assert after.replanned == robot.replans[0].reason and samples_free(robot.grid, after.path)
    assert np.allclose(walked[-1], EAST_ROOM)
    assert path_length(walked) > path_length(path)


def test_a_zone_switching_on_around_the_robot_makes_it_step_out_first(site_grid):
    robot = Navigator(site_grid, np.array([8.5, 8.0]), zones_at=lambda t: worker_keepouts(
        [("worker-002", (8.0, 8.0), t >= 5.0)], live_radius=2.0), zone_changes=[5.0])
    robot.wait(6.0)
    walked = robot.go((3.0, 9.0))
    assert robot.legs[0].replanned.startswith("stepped out")
    assert np.linalg.norm(walked[1] - (8.0, 8.0)) >= 2.0 and np.allclose(walked[-1], (3.0, 9.0))


def test_a_goal_inside_a_zone_in_force_is_a_planning_error(site_grid):
    robot = Navigator(site_grid, DOCK, zones_at=lambda t: [KeepOut.circle("grinding", (9.0, 8.0), 2.0)])
    with pytest.raises(PlanningError, match="inside grinding"):
        robot.go((9.0, 8.0))
    assert np.allclose(robot.position, DOCK)
