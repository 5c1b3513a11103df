"""A person in view must not make a single frame's global search confidently wrong: the tour's south-west corner
turned 30 degrees right, a person close in front of the camera (neither their head nor their feet in view). Part
of the person lands on a column's face at a place 13.5 m away, which then out-scored every other place; counted
whole or not at all (``localization.pieces``), the person earns no place anything and the view is refused as
ambiguous, as it is with nobody there, by find_pose and by verify with no prior. The pieces themselves: a person standing on the floor in front of a wall is
one thing, the wall and the floor are not; and a thing on a surface only in part earns no pose its points."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import trimesh
from loc_helpers import errors, frame, offset

from bim2rdt.localization import GlobalSearchConfig, choose, find_pose
from bim2rdt.localization.pieces import NOT_A_THING, free_standing
from bim2rdt.localization.view_score import ViewScore
from bim2rdt.sim.tour import tour_poses


@pytest.fixture(scope="module")
def turned_corner(built):
    """The corner station turned 30 degrees to the right: a person fills a quarter of the frame."""
    T = offset(tour_poses(10.0)[0], dyaw_deg=-30.0)
    return frame(built, T, 2), T


def _taken(candidates, config, T_true):
    best, reason = choose(candidates, config)
    if best is None:
        return None, reason
    position, yaw = errors(best.pose, T_true)
    return (float(np.linalg.norm(position)), float(yaw)), reason


def test_a_person_in_view_does_not_make_a_wrong_place_confident(site_model, turned_corner):
    data, T = turned_corner
    config = GlobalSearchConfig()
    taken, reason = _taken(find_pose(data, site_model, config=config), config, T)
    assert taken is None or (taken[0] < 0.05 and abs(taken[1]) < 1.0), (taken, reason)


def test_with_every_point_counted_on_its_own_the_same_frame_is_confidently_wrong(site_model, turned_corner):
    """The control: the frame above is the trap it is meant to be (the wrong place is taken without the rule)."""
    data, T = turned_corner
    config = GlobalSearchConfig(thing_whole=0.0)
    taken, reason = _taken(find_pose(data, site_model, config=config), config, T)
    assert taken is not None and taken[0] > 5.0, (taken, reason)


def _surface(x0, x1, y0, y1, z0, z1, step=0.05):
    """Points on an axis-aligned rectangle (one of the ranges a single value), metres."""
    xs, ys, zs = (np.arange(a, b + 1e-9, step) if b > a else np.array([a]) for a, b in ((x0, x1), (y0, y1), (z0, z1)))
    return np.stack([g.ravel() for g in np.meshgrid(xs, ys, zs, indexing="ij")], axis=1)


def test_a_person_standing_on_the_floor_before_a_wall_is_a_thing_and_the_wall_and_floor_are_not():
    wall = _surface(4.0, 4.0, -3.0, 3.0, 0.0, 2.5)               # a wall 4 m ahead (z up, levelled)
    floor = _surface(0.5, 4.0, -3.0, 3.0, 0.0, 0.0)
    person = _surface(2.0, 2.0, -0.25, 0.25, 0.0, 1.75)          # 2 m in front of it, feet on the floor
    points = np.concatenate([wall, floor, person])
    labels = free_standing(points, points[:, 2], link=0.15, floor=0.1, extent=2.2)
    of_person = labels[len(wall) + len(floor):]
    on_floor = points[:, 2] < 0.1
    assert len(np.unique(of_person[points[len(wall) + len(floor):, 2] >= 0.1])) == 1 and of_person.max() >= 0
    assert np.all(labels[: len(wall)][~on_floor[: len(wall)]] == NOT_A_THING)
    assert np.all(labels[on_floor] == NOT_A_THING)


def _scene(*boxes):
    meshes = [trimesh.creation.box(extents=e, transform=trimesh.transformations.translation_matrix(c))
              for c, e in boxes]
    owner = np.concatenate([np.full(len(m.faces), 0) for m in meshes])
    return SimpleNamespace(mesh=trimesh.util.concatenate(meshes), face_owner=owner)


def test_a_thing_on_a_surface_only_in_part_earns_a_pose_none_of_its_points():
    """A 0.5 m wide 'person' face 2 m ahead; a 0.3 m wide column face there explains 60 % of it."""
    column = ((2.15, 0.1, 0.0), (0.3, 0.3, 4.0))     # its face at x = 2, y from -0.05 to 0.25
    wall = ((6.1, 0.0, 0.0), (0.2, 40.0, 10.0))      # far behind, so every ray meets a surface
    points = _surface(2.0, 2.0, -0.25, 0.25, -0.5, 0.5)
    things = np.zeros(len(points), dtype=int)
    scene = _scene(column, wall)
    each = ViewScore(points, scene, on=0.06, behind=0.1).evidence(np.eye(4))
    whole = ViewScore(points, scene, on=0.06, behind=0.1, things=things, whole=0.8).evidence(np.eye(4))
    assert 0.5 < each.on / each.counted < 0.7          # counted point by point, the column earns its 60 %
    assert whole.on == 0 and whole.in_front == whole.counted
    wide = ((2.15, 0.0, 0.0), (0.3, 1.0, 4.0))          # a column face that explains it whole
    assert ViewScore(points, _scene(wide, wall), 0.06, 0.1, things, 0.8).evidence(np.eye(4)).on == len(points)


def test_a_sparsely_sampled_wall_stays_one_piece_and_is_no_thing():
    """A 6 m wall sampled 20 cm apart (a far wall of a cloud thinned to its cap): beyond the fixed 15 cm reach of
    each other, each point would be a thing of its own; the reach grows with the spacing, so the wall stays one
    piece, too large to be a thing."""
    wall = _surface(4.0, 4.0, -3.0, 3.0, 0.3, 2.5, step=0.2)
    labels = free_standing(wall, wall[:, 2], link=0.15, floor=0.1, extent=2.2)
    assert np.all(labels == NOT_A_THING)


def test_verify_with_no_prior_does_not_accept_the_frame_at_a_wrong_place(site_model, turned_corner):
    """verify's own path: the frame, its pose stripped, searched on the BIM by the tracker: refused as ambiguous,
    or accepted within 5 cm and 1 degree, never elsewhere."""
    from dataclasses import replace

    from bim2rdt.verify import verify_frames

    data, T = turned_corner
    [result] = verify_frames([replace(data, T_world_camera=None)], site_model).frames
    assert result.prior_source == "global"
    if result.accepted:
        position, yaw = errors(result.pose, T)
        assert np.linalg.norm(position) < 0.05 and abs(yaw) < 1.0, (position, yaw)
    else:
        assert result.reason.startswith("ambiguous: "), result.reason


def test_a_sweep_carrying_the_wrong_place_through_that_frame_scores_the_person_whole_too(site_model, turned_corner):
    """The sweep re-scores the places it carries by the same rule: carried onto the frame (no motion), the trap's
    place scores no more than the truth with the rule, and more without it (the control)."""
    from bim2rdt.localization.hypotheses import carry

    data, T = turned_corner
    wrong = choose(find_pose(data, site_model, config=GlobalSearchConfig(thing_whole=0.0)),
                   GlobalSearchConfig(thing_whole=0.0))[0]
    assert wrong is not None and np.linalg.norm(wrong.pose[:3, 3] - T[:3, 3]) > 5.0
    truth = type(wrong)(T, 0.0, None, [], False, 0.0, wrong.storey, wrong.gravity)

    def scores(config):
        carried = carry([truth, wrong], data, np.eye(4), site_model, config=config)
        near = {bool(np.linalg.norm(c.pose[:3, 3] - T[:3, 3]) < 1.0): c.score for c in carried if c.refined}
        return near[True], near[False]

    right, trap = scores(GlobalSearchConfig())
    assert trap <= right + 1e-6, (right, trap)
    right, trap = scores(GlobalSearchConfig(thing_whole=0.0))
    assert trap > right, (right, trap)
