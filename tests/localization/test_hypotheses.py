"""Multi-hypothesis global localization through a sweep (``localization.Sweep``): the south-west corner of the
embedded site, ambiguous alone (several corners look alike), is resolved by the next station's frame carried there
by the odometry, and its own pose back-filled through the odometry chain, both within 5 cm and 1 degree; a robot
that stands still resolves nothing, and nothing is taken while two places fit."""

from __future__ import annotations

import numpy as np
import pytest
from loc_helpers import errors, frame, offset

from bim2rdt.localization import Sweep, refix
from bim2rdt.localization.hypotheses import fitting
from bim2rdt.sim.tour import tour_poses


def up_of(T):
    return T[:3, :3].T @ np.array([0.0, 0.0, 1.0])  # the IMU's up in the camera frame


@pytest.fixture(scope="module")
def corner_then_unique(site_model, built):
    """Stations 0 (the corner) and 1 (the interior walls' ends) of the tour, their frames and true poses."""
    poses = tour_poses(10.0)[:2]
    return [frame(built, T, seed) for seed, T in enumerate(poses)], poses


@pytest.fixture(scope="module")
def first_step(site_model, corner_then_unique):
    """The corner searched alone: the sweep and its step."""
    frames, poses = corner_then_unique
    sweep = Sweep(site_model, recheck=False)
    return sweep, sweep.add(frames[0], None, up_of(poses[0]))


def test_a_corner_alone_is_held_ambiguous_with_its_places_as_hypotheses(first_step):
    sweep, step = first_step
    assert step.pose is None and step.reason.startswith("ambiguous: ")
    assert len(step.places) >= 2 and step.how == "search"
    assert len({tuple(np.round(p.pose[:2, 3])) for p in step.places}) >= 2  # different places


def test_the_next_frame_carried_by_drifting_odometry_resolves_the_corner_and_back_fills_it(site_model,
                                                                                           corner_then_unique):
    frames, poses = corner_then_unique
    sweep = Sweep(site_model, recheck=False)
    sweep.add(frames[0], None, up_of(poses[0]))
    # the robot's odometry of the 6.8 m leg: 2 % of it off sideways and a 0.6 degree turn too many
    measured = offset(poses[1], dx=0.1, dy=-0.08, dyaw_deg=0.6)
    step = sweep.add(frames[1], np.linalg.inv(poses[0]) @ measured, up_of(poses[1]))
    assert step.pose is not None, step.reason
    assert step.how == "carried" and step.resolved_at == 1 and len(step.places) == 1
    position, yaw = errors(step.pose, poses[1])
    assert np.linalg.norm(position) < 0.05 and abs(yaw) < 1.0, (position, yaw)
    [(held, prior)] = step.backfill
    assert held == 0
    back = refix(frames[0], prior, site_model, up_of(poses[0]))
    assert back.refined and not back.degenerate, back.reason
    position, yaw = errors(back.pose, poses[0])
    assert np.linalg.norm(position) < 0.05 and abs(yaw) < 1.0, (position, yaw)


def test_standing_still_resolves_nothing_and_no_pose_is_taken_while_two_places_fit(site_model, corner_then_unique,
                                                                                  first_step):
    frames, poses = corner_then_unique
    sweep, first = first_step
    step = sweep.add(frames[0], np.eye(4), up_of(poses[0]))  # the same view again: no motion to tell them apart
    assert step.pose is None and step.reason.startswith("ambiguous: ")
    assert len(fitting(step.places)) >= 2 and step.how == "carried"
    assert step.backfill == []


def test_a_wrong_odometry_step_takes_no_pose(site_model, corner_then_unique):
    """The places moved 2.5 m and 30 degrees off where the robot went: none fits the new frame, nothing is taken."""
    frames, poses = corner_then_unique
    sweep = Sweep(site_model, recheck=False)
    sweep.add(frames[0], None, up_of(poses[0]))
    wrong = offset(poses[1], dx=-2.0, dy=1.5, dyaw_deg=30.0)
    step = sweep.add(frames[1], np.linalg.inv(poses[0]) @ wrong, up_of(poses[1]))
    assert step.pose is None and step.backfill == [] and step.resolved_at is None
    assert fitting(step.places) == []  # carried on unconfirmed, none fixed


def test_a_frame_whose_own_search_disagrees_with_the_carried_places_takes_no_wrong_pose(site_model, built,
                                                                                       corner_then_unique):
    """The corner turned 30 degrees to the right: searched alone, that frame's best place is another one (a wall
    there explains the person standing in view), away from every carried place. The carried places go on; no
    pose is taken unless it is the true one."""
    frames, poses = corner_then_unique
    sweep = Sweep(site_model)
    sweep.add(frames[0], None, up_of(poses[0]))
    turned = offset(poses[0], dyaw_deg=-30.0)
    step = sweep.add(frame(built, turned, 2), np.linalg.inv(poses[0]) @ turned, up_of(turned))
    if step.pose is not None:
        position, yaw = errors(step.pose, turned)
        assert np.linalg.norm(position) < 0.05 and abs(yaw) < 1.0, (position, yaw)
    assert step.how == "carried" and len(step.places) >= 2
