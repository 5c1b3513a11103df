"""A station whose view leaves a direction free turns and looks again; a pinned one does not."""

from __future__ import annotations

import numpy as np

from bim2rdt.localization import LocalizationConfig, OdometryNoise, PoseFilter, localize_station, pinned
from bim2rdt.localization.planar import to_planar
from bim2rdt.perception import look_at
from bim2rdt.sim.robot import SimulatedRobot
from loc_helpers import offset

SOUTH_WALL = look_at((11.0, 2.5, 1.1), (11.0, 0.3, 0.8))
"""The south wall square on: blind along it."""


def _drifted_filter(truth, dx=0.12, dy=-0.05):
    state, _ = to_planar(offset(truth, dx, dy, 1.0))
    return PoseFilter(state, np.diag([0.15**2, 0.15**2, 1e-4, np.deg2rad(2.0) ** 2]), OdometryNoise())


def test_a_lone_wall_makes_the_robot_look_around_until_the_station_is_pinned(site_model, bare):
    robot = SimulatedRobot(bare.scene, SOUTH_WALL, seed=1)
    pose_filter = _drifted_filter(SOUTH_WALL)
    _, tilt = to_planar(SOUTH_WALL)
    looks = localize_station(pose_filter, site_model, robot.capture(), tilt, robot.turn)
    assert not pinned(looks[0]) and looks[0].fix.degenerate  # the wall alone leaves x free
    assert len(looks) >= 2 and pinned(looks[-1])
    assert np.linalg.norm(pose_filter.state[:3] - robot.T_world_camera[:3, 3]) < 0.01


def test_without_look_around_the_position_along_the_wall_keeps_the_odometrys_error(site_model, bare):
    robot = SimulatedRobot(bare.scene, SOUTH_WALL, seed=1)
    pose_filter = _drifted_filter(SOUTH_WALL)
    _, tilt = to_planar(SOUTH_WALL)
    looks = localize_station(pose_filter, site_model, robot.capture(), tilt, robot.turn,
                             LocalizationConfig(look_around_deg=()))
    assert len(looks) == 1
    assert abs(pose_filter.state[0] - SOUTH_WALL[0, 3]) > 0.1  # still the prior's 12 cm along the wall
    assert abs(pose_filter.state[1] - SOUTH_WALL[1, 3]) < 0.01  # across it: fixed


def test_a_pinned_station_does_not_turn(site_model, bare):
    corner = look_at((8.5, 2.0, 1.1), (11.85, 6.5, 0.8))
    robot = SimulatedRobot(bare.scene, corner, seed=2)
    _, tilt = to_planar(corner)
    looks = localize_station(_drifted_filter(corner), site_model, robot.capture(), tilt, robot.turn)
    assert len(looks) == 1 and pinned(looks[0])
    assert np.allclose(robot.T_world_camera, corner)


def test_turning_back_leaves_the_camera_on_the_stations_view_with_a_pinned_pose(site_model, bare):
    robot = SimulatedRobot(bare.scene, SOUTH_WALL, seed=1)
    pose_filter = _drifted_filter(SOUTH_WALL)
    _, tilt = to_planar(SOUTH_WALL)
    looks = localize_station(pose_filter, site_model, robot.capture(), tilt, robot.turn, turn_back=True)
    assert len(looks) >= 3 and looks[-1].applied
    assert abs(to_planar(robot.T_world_camera)[0][3] - to_planar(SOUTH_WALL)[0][3]) < np.deg2rad(2.0)
    assert np.linalg.norm(pose_filter.state[:3] - robot.T_world_camera[:3, 3]) < 0.01
