"""Global localization without a prior (``localization.find_pose``): the real office1 frame found on its BIM from
the floor's gravity alone; a corner of the embedded site, which looks the same from several corners, is refused
as ambiguous with every candidate listed; a station whose view is unique is found within 5 cm and 1 degree; the
coarse search's correlation puts a point's surface at the right cell."""

from __future__ import annotations

import numpy as np
import pytest
from loc_helpers import errors, frame

from bim2rdt.localization import Candidate, GlobalSearchConfig, LocalizationError, choose, find_pose
from bim2rdt.localization.global_map import StoreyPlan
from bim2rdt.localization.global_search import correlate, noise
from bim2rdt.sim.tour import tour_poses
from bim2rdt.verify.chain import real_sensor_localization

REAL = GlobalSearchConfig(fix=real_sensor_localization())


def test_office1_is_found_without_a_prior_within_5_cm_and_2_degrees(office1):
    candidates = find_pose(office1.frame, office1.model, config=REAL)
    best, reason = choose(candidates, REAL)
    assert best is not None, reason
    offset, yaw = errors(best.pose, office1.T_world_camera)
    assert np.linalg.norm(offset) < 0.05 and abs(yaw) < 2.0, (offset, yaw)
    assert best.gravity == "floor" and best.storey == "Office floor"
    assert best.covariance.shape == (6, 6) and best.degenerate == []
    assert all(isinstance(c, Candidate) for c in candidates) and candidates[0] is best


def test_an_imu_up_is_used_when_given_and_gives_the_same_place(office1):
    up_sensor = office1.T_world_camera[:3, :3].T @ np.array([0.0, 0.0, 1.0])
    best, reason = choose(find_pose(office1.frame, office1.model, up=up_sensor, config=REAL), REAL)
    assert best is not None, reason
    assert best.gravity == "given"
    offset, yaw = errors(best.pose, office1.T_world_camera)
    assert np.linalg.norm(offset) < 0.05 and abs(yaw) < 2.0


def test_an_unknown_storey_is_refused_naming_the_storeys(office1):
    with pytest.raises(LocalizationError, match="no storey 'Roof'.*Office floor"):
        find_pose(office1.frame, office1.model, config=REAL, storey="Roof")


@pytest.fixture(scope="module")
def stations(site_model, built):
    poses = tour_poses(10.0)
    return [(T, frame(built, T, seed)) for seed, T in enumerate(poses[:2])]


def test_a_corner_seen_alike_from_several_corners_is_ambiguous_and_lists_every_candidate(site_model, stations):
    T_true, corner = stations[0]  # the south-west corner: two walls meeting, as at every corner of the site
    candidates = find_pose(corner, site_model)
    best, reason = choose(candidates)
    assert best is None and reason.startswith("ambiguous: ") and reason.endswith(" places fit")
    count = int(reason.split()[1])
    fits = [c for c in candidates if c.refined]
    unchecked = [c for c in candidates if c.extra.get("unchecked")]  # beyond the fixes' budget, might tie
    tie = fits[0].score - noise(fits[0].score, GlobalSearchConfig())
    assert count >= 2 and count == sum(c.score >= tie for c in fits + unchecked)
    places = {tuple(np.round(c.pose[:2, 3])) for c in fits if c.score >= tie}
    assert len(places) >= 2  # different places, each fixed, not one place found twice


def test_a_unique_view_is_found_within_5_cm_and_1_degree(site_model, stations):
    T_true, view = stations[1]  # the interior walls' ends and a column
    best, reason = choose(find_pose(view, site_model))
    assert best is not None, reason
    offset, yaw = errors(best.pose, T_true)
    assert np.linalg.norm(offset) < 0.05 and abs(yaw) < 1.0, (offset, yaw)


def test_the_correlation_scores_a_point_on_the_surface_at_the_sensors_true_cell():
    likelihood = np.zeros((40, 50))
    likelihood[30, 20] = 1.0  # one surface cell: world (2.05, 3.05) at 0.1 m cells from the origin
    plan = StoreyPlan("test", 0.0, np.zeros(2), 0.1, likelihood, np.zeros((40, 50), bool), np.ones((40, 50), bool))
    point = np.array([[1.0, 0.5]])  # seen 1 m ahead, 0.5 m left in the sensor's levelled frame
    yaw = np.deg2rad(90.0)  # turned to face +y: the point lies 0.5 m towards -x, 1 m towards +y
    scores = correlate(plan, point, np.array([0.0, yaw]), through_weight=0.0)
    row, col = np.unravel_index(np.argmax(scores[1]), scores[1].shape)
    assert (row, col) == (20, 25) and scores[1, row, col] == pytest.approx(1.0)
    assert np.argmax(scores[0]) != np.argmax(scores[1])


def test_a_scan_in_a_cameras_axes_finds_its_floor_along_another_axis_and_its_place(office1):
    """office1's points as a cloud (no image): a scanner's usual up (+z) sees no floor, the camera's -y does."""
    from bim2rdt.sources import Cloud
    from bim2rdt.localization import depth_points

    cloud = Cloud(depth_points(office1.frame), None, None, office1.model.path)
    best, reason = choose(find_pose(cloud, office1.model, config=REAL), REAL)
    assert best is not None, reason
    offset, yaw = errors(best.pose, office1.T_world_camera)
    assert np.linalg.norm(offset) < 0.05 and abs(yaw) < 2.0, (offset, yaw)
    assert best.gravity == "floor"


def test_a_columns_solid_cells_are_its_own_not_grown_so_a_ray_past_its_edge_is_not_through_it(site_model):
    """Column C11 (0.4 m square at (6, 5)): the cells whose centre lies in it are solid, those 10 cm off its
    faces are not (grown by a cell, rays past its edge cost the true place: the tour's stations 6 and 16)."""
    from bim2rdt.localization.global_map import storey_plans

    cfg = GlobalSearchConfig()
    [plan] = storey_plans(site_model, None, cfg.resolution, cfg.band, cfg.sigma, cfg.clearance)
    rows, cols = np.nonzero(plan.solid)
    centres = plan.centre(rows, cols)
    near = np.all(np.abs(centres - (6.0, 5.0)) < 0.6, axis=1)
    assert near.sum() > 0
    low, high = centres[near].min(axis=0), centres[near].max(axis=0)
    assert np.all(high - low <= 0.4 + 1e-9), (low, high)  # at most 0.4 m between the outer cells' centres
    assert np.all(high - low >= 0.2 - 1e-9)


def _candidate(x, score, refined=True, degenerate=(), covariance=None, **extra):
    pose = np.eye(4)
    pose[0, 3] = x
    return Candidate(pose, score, covariance, [np.array(d, float) for d in degenerate], refined, score, "s", "imu",
                     extra=dict(extra))


def test_fixes_of_one_place_merge_within_their_covariance_and_along_a_direction_the_view_cannot_fix():
    from bim2rdt.localization.global_search import same_place

    cfg = GlobalSearchConfig()
    loose = np.diag([0.1**2] * 3 + [1e-4] * 3)  # 10 cm sigma: 30 cm apart is the same place
    assert same_place(_candidate(0.0, 0.9, covariance=loose), _candidate(0.25, 0.9, covariance=loose), cfg)
    assert not same_place(_candidate(0.0, 0.9), _candidate(0.25, 0.9), cfg)  # no covariance: 15 cm
    along = [(1.0, 0.0, 0.0)]  # a wall along x: its fixes slide along it
    assert same_place(_candidate(0.0, 1.0, degenerate=along), _candidate(3.0, 1.0, degenerate=along), cfg)


def test_a_place_left_unfixed_that_screens_within_noise_of_the_best_makes_the_view_ambiguous():
    """Never take a pose while a place not yet fixed might fit as well (a confident wrong pose must never
    happen); a place screened far below does not count."""
    best = _candidate(0.0, 0.9)
    tie = _candidate(5.0, 0.88, refined=False, unchecked=True)
    taken, reason = choose([best, tie])
    assert taken is None and reason == "ambiguous: 2 places fit"
    taken, reason = choose([best, _candidate(5.0, 0.5, refined=False, unchecked=True)])
    assert taken is best and reason == ""


def test_a_view_whose_walls_fit_elsewhere_but_leave_clutter_in_free_space_there_is_found(site_model, built):
    """Tour station 6 (a column, the interior wall with its door, the north wall): three other places fit its
    walls, but there points lie in free space or beyond a wall; refused as ambiguous before the whole-view
    likelihood."""
    T_true = tour_poses(100.0)[6]
    view = frame(built, T_true, 6)
    best, reason = choose(find_pose(view, site_model))
    assert best is not None, reason
    offset, yaw = errors(best.pose, T_true)
    assert np.linalg.norm(offset) < 0.05 and abs(yaw) < 1.0, (offset, yaw)
