"""The whole-view likelihood the global search ranks and ties candidates by: a point on the first surface its ray
meets earns one, a point seen through a wall costs one, a point in free space earns nothing, a point behind one
of the model's other bodies (it may have moved) costs nothing; distances are taken along the surface's normal,
so a wall seen at a grazing angle is not lost to a pose a few centimetres off."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import trimesh

from bim2rdt.localization.view_score import ViewScore


def _scene(*boxes):
    """Boxes (centre, extents, owner) as an OccludedMap-like scene: owner >= 0 a map element, < 0 another body."""
    meshes = [trimesh.creation.box(extents=e, transform=trimesh.transformations.translation_matrix(c))
              for c, e, _ in boxes]
    owner = np.concatenate([np.full(len(m.faces), o) for m, (_, _, o) in zip(meshes, boxes)])
    return SimpleNamespace(mesh=trimesh.util.concatenate(meshes), face_owner=owner)


WALL = ((2.1, 0.0, 0.0), (0.2, 40.0, 10.0), 0)  # its near face at x = 2, facing the sensor at the origin


def test_on_through_and_in_front_count_plus_one_minus_one_and_nothing():
    points = np.array([[2.0, 0.0, 0.0],     # on the wall
                       [4.0, 0.5, 0.0],     # beyond it: seen through the wall
                       [1.0, -0.5, 0.0],    # short of it: clutter in free space
                       [-3.0, 0.0, 0.0]])   # no surface on its ray
    evidence = ViewScore(points, _scene(WALL), on=0.06, behind=0.1).evidence(np.eye(4))
    assert (evidence.on, evidence.through, evidence.in_front, evidence.counted) == (1, 1, 1, 4)
    assert evidence.score == pytest.approx((1 - 1) / 4)


def test_a_point_behind_another_body_costs_nothing_but_still_counts():
    cabinet = ((1.0, 0.0, 0.0), (0.2, 0.4, 0.4), -1)
    points = np.array([[2.0, 0.0, 0.0], [2.0, 1.0, 0.0]])  # the first behind the cabinet, the second on the wall
    evidence = ViewScore(points, _scene(WALL, cabinet), on=0.06, behind=0.1).evidence(np.eye(4))
    assert (evidence.on, evidence.through, evidence.counted) == (1, 0, 2)


def test_a_wall_seen_at_a_grazing_angle_stays_on_it_for_a_pose_a_few_centimetres_off():
    """Along the ray a 5 cm shift across the wall moves the hit by 5 cm / cos(80 deg) = 29 cm; along the normal,
    5 cm: within a 25 cm tolerance."""
    direction = np.array([np.cos(np.deg2rad(80.0)), np.sin(np.deg2rad(80.0)), 0.0])
    point = direction * (2.0 / direction[0])  # on the wall's face x = 2, 11.5 m off
    score = ViewScore(point[None], _scene(WALL), on=0.25, behind=0.25)
    off = np.eye(4)
    off[0, 3] = -0.05  # the sensor 5 cm farther from the wall
    assert score.evidence(off).on == 1 and score.evidence(off).through == 0
