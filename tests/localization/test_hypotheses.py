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


# --- a bare wall taken from the odometry calibrated online (decision 0053) ---

BIAS = (0.02, -0.012, np.deg2rad(0.15))
"""What the robot's odometry misses per metre walked: along m/m, across m/m, heading rad/m."""


def biased(T_start, T_end, bias=BIAS):
    """The odometry's step from T_start to T_end when it misses ``bias`` per metre (the error is the end less
    the odometry's: ``a L`` along the leg, ``b L + c L^2 / 2`` across, ``c L`` of heading)."""
    a, b, c = bias
    d = T_end[:2, 3] - T_start[:2, 3]
    length = float(np.linalg.norm(d))
    u = d / length
    n = np.array([-u[1], u[0]])
    shift = u * a * length + n * (b * length + c * length**2 / 2)
    return np.linalg.inv(T_start) @ offset(T_end, -shift[0], -shift[1], -np.rad2deg(c * length))


def history(sweep, bias=BIAS, legs=10, noise=0.001, seed=0):
    """``legs`` legs before the sweep's first frame (numbers -legs..-1), each between two fixes, walked with
    ``bias`` per metre and ``noise`` m per metre of random error: what the sweep would have recorded."""
    rng = np.random.default_rng(seed)
    T = offset(np.eye(4), 30.0, -20.0, 10.0)
    sweep.confirm(-legs - 1, T)
    for k in range(-legs, 0):
        end = offset(T, *rng.uniform(-5.0, 5.0, 2), rng.uniform(-120.0, 120.0))
        step = biased(T, end, bias)
        step[:2, 3] += rng.normal(0.0, noise * np.linalg.norm(end[:2, 3] - T[:2, 3]), 2)
        sweep.steps[k] = step
        sweep.confirm(k, end)
        T = end


@pytest.fixture(scope="module")
def to_the_wall(site_model, built):
    """Stations 0-2: the corner, the interior walls' ends (resolving the corner), the south wall square on."""
    poses = tour_poses(20.0)[:3]
    return [frame(built, T, seed) for seed, T in enumerate(poses)], poses


def walk_to_the_wall(site_model, to_the_wall, before=None):
    frames, poses = to_the_wall
    sweep = Sweep(site_model, recheck=False)
    if before is not None:
        before(sweep)
    sweep.add(frames[0], None, up_of(poses[0]))
    resolved = sweep.add(frames[1], biased(poses[0], poses[1]), up_of(poses[1]))
    assert resolved.pose is not None, resolved.reason
    return sweep, sweep.add(frames[2], biased(poses[1], poses[2]), up_of(poses[2]))


def test_a_bare_wall_is_refused_without_calibration(site_model, to_the_wall):
    sweep, step = walk_to_the_wall(site_model, to_the_wall)
    assert step.pose is None and "cannot fix 1 direction" in step.reason and "not calibrated" in step.reason
    assert step.calibration["valid"] is False and 2 in sweep.free
    position, _ = errors(step.places[0].pose, to_the_wall[1][2])
    assert np.linalg.norm(position) > 0.05  # the raw odometry's place: wrong along the wall, so rightly refused


def test_a_bare_wall_is_taken_from_the_calibrated_odometry(site_model, to_the_wall):
    sweep, step = walk_to_the_wall(site_model, to_the_wall, history)
    assert step.pose is not None and step.how == "calibrated", step.reason
    assert step.calibration["applied"] and step.calibration["legs"] == 10  # frame 0 is back-filled, unconfirmed
    position, yaw = errors(step.pose, to_the_wall[1][2])
    assert np.linalg.norm(position) < 0.02 and abs(yaw) < 1.0, (position, yaw)
    assert 2 not in sweep.free and 2 not in sweep.fixes  # taken, but no fix to calibrate from


def test_a_bare_wall_is_refused_when_the_legs_are_inconsistent(site_model, to_the_wall):
    """Legs with 3 % of random error per metre: the calibration validates nothing precise enough."""
    sweep, step = walk_to_the_wall(site_model, to_the_wall,
                                   lambda s: history(s, bias=(0.0, 0.0, 0.0), noise=0.03, seed=1))
    assert step.pose is None and "more than 5 cm" in step.reason, step.reason
    assert step.calibration["valid"]


def test_smoothing_takes_a_bare_wall_from_the_fixes_on_both_sides(site_model):
    """A frame fixed but for x (a wall along x), between two fixes, its odometry calibrated: :meth:`smooth`
    completes it from both sides; inconsistent steps on the two sides leave it refused."""
    truth = [offset(np.eye(4), 2.0 + 3.0 * k, 1.0 + 0.5 * k, 20.0 * k) for k in range(3)]

    def sweep_with(step_after):
        sweep = Sweep(site_model)
        history(sweep)
        sweep.count = 3
        sweep.confirm(0, truth[0])
        sweep.confirm(2, truth[2])
        sweep.steps[1], sweep.steps[2] = biased(truth[0], truth[1]), step_after
        sweep.free[1] = (offset(truth[1], dx=0.3), [np.array([1.0, 0.0, 0.0])])  # 30 cm off along the wall
        return sweep

    [(number, pose)] = sweep_with(biased(truth[1], truth[2])).smooth()
    position, yaw = errors(pose, truth[1])
    assert number == 1 and np.linalg.norm(position) < 0.005 and abs(yaw) < 0.01
    assert sweep_with(biased(truth[1], offset(truth[2], dx=0.25))).smooth() == []  # the two sides disagree
