"""Scan-vs-BIM: what the building explains in a frame, along each ray and then in 3-D.

The 3-D test exists for silhouettes: a pixel whose ray passes just beside a column's edge hits the wall behind,
while the depth it measured (a mixed pixel, a camera pose a few mm off) lies on the column. By its own ray that
point is in front of the BIM; in the demo 129 such points of Column C11's corner became a detection."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import trimesh

from bim2rdt.perception import GeometricDetector, look_at, locate_detections
from bim2rdt.perception.background import BimStructure, explained, on_any_surface
from bim2rdt.perception.surfaces import KnownSurface

from bim2rdt.sim.meshes import mesh_for_family

from tests.perception.conftest import DRUM, placed, render

C11_FRONT_Y, C11_EAST_X = 4.8, 6.2  # Column C11: 400 mm square centred at (6, 5)
TOLERANCE, SIGMA = 0.02, 0.006
DRUM_OFF = mesh_for_family(DRUM).extents[0] / 2 + 0.005  # a drum's axis 5 mm off a face it stands against


def _explained(structure: BimStructure, origin, through, distance: float) -> bool:
    """Whether the point ``distance`` m from ``origin`` on the ray towards ``through`` is explained."""
    direction = np.asarray(through, dtype=float) - origin
    direction /= np.linalg.norm(direction)
    return bool(explained(structure, origin, direction[None], np.array([distance]), TOLERANCE,
                          np.array([SIGMA]), 0.0, 0.015)[0])


def test_a_point_on_a_columns_edge_whose_ray_passes_beside_the_column_is_the_columns(site):
    """3 mm beside C11's vertical edge, on the plane of its front face: the ray goes on to the wall behind, so
    by the ray alone the point stands metres in front of the BIM; in 3-D it is on the column."""
    structure = BimStructure(site)
    origin = np.array([6.0, 2.0, 1.0])
    beside_edge = np.array([C11_EAST_X + 0.003, C11_FRONT_Y, 1.0])
    direction = (beside_edge - origin) / np.linalg.norm(beside_edge - origin)
    distance = float(np.linalg.norm(beside_edge - origin))
    t, _ = structure.cast(origin, direction[None])
    assert t[0] > distance + 1.0  # the BIM's surface on this ray is the wall, far behind the point
    assert _explained(structure, origin, beside_edge, distance)


def test_a_point_off_a_columns_edge_by_more_than_the_tolerance_is_kept(site):
    """5 cm beside the edge (an object standing there) is not the column's, nor is a point 10 cm in front of
    the column's face on a ray that hits it."""
    structure = BimStructure(site)
    origin = np.array([6.0, 2.0, 1.0])
    off_edge = np.array([C11_EAST_X + 0.05, C11_FRONT_Y, 1.0])
    assert not _explained(structure, origin, off_edge, float(np.linalg.norm(off_edge - origin)))
    assert not _explained(structure, origin, (6.0, C11_FRONT_Y, 1.0), C11_FRONT_Y - 2.0 - 0.10)


def _unit_box() -> KnownSurface:
    return KnownSurface.of_mesh("box", trimesh.creation.box(extents=(1.0, 1.0, 1.0)))  # faces at +-0.5


@pytest.mark.parametrize("direction, on_surface", [
    ((-1.0, 0.0, 0.0), True),   # the ray runs along the way to the face: depth noise moves the point off it
    ((0.0, 1.0, 0.0), False),   # the ray grazes the face: depth noise moves the point along it, not off it
])
def test_depth_noise_counts_as_far_as_the_ray_runs_towards_the_surface(direction, on_surface):
    """2.5 cm off the face x = 0.5 with 1 cm of depth noise: within 2 cm + 3 sigma only when the ray runs
    along the offset (the per-ray test's 'seen along the normal')."""
    point = np.array([[0.525, 0.0, 0.0]])
    assert on_any_surface([_unit_box()], point, np.array([direction]), TOLERANCE, np.array([0.01]))[0] == on_surface


def test_any_element_explains_a_point_near_it_and_none_a_point_far_from_all():
    """Two boxes 5 m apart: a point 1 cm off the first and one 1.5 cm off the second's top are theirs, one 10 cm
    off the first is not, and without the first box nothing explains its point."""
    far = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    far.apply_translation((5.0, 0.0, 0.0))
    far = KnownSurface.of_mesh("far", far)
    points = np.array([[0.51, 0.0, 0.0], [0.6, 0.0, 0.0], [5.0, 0.0, 0.515]])
    rays = np.tile([0.0, 0.0, 1.0], (3, 1))
    assert on_any_surface([far, _unit_box()], points, rays, TOLERANCE, np.zeros(3)).tolist() == [True, False, True]
    assert on_any_surface([far], points[:1], rays[:1], TOLERANCE, np.zeros(1)).tolist() == [False]


def test_the_bare_building_seen_from_a_pose_a_few_mm_off_holds_nothing_to_detect(site, priors):
    """A localized robot's camera pose is a few mm off: every silhouette of a column then has a strip of pixels
    whose rays pass beside it while their depth lies on it. None of it is an object."""
    frame, _ = render(site, [], look_at((8.5, 2.0, 1.1), (6.0, 5.0, 0.8)))
    T_off = frame.T_world_camera.copy()
    T_off[0, 3] += 0.005
    assert GeometricDetector(site, priors).detect(replace(frame, T_world_camera=T_off)) == []


@pytest.mark.parametrize("where, centre_xy, eye", [
    ("C11's front face", (6.0, C11_FRONT_Y - DRUM_OFF), (8.0, 2.5, 1.1)),
    ("the south wall", (3.0, 0.3 + DRUM_OFF), (4.5, 3.5, 1.1)),
])
def test_a_drum_standing_5_mm_off_a_column_or_a_wall_keeps_its_points(site, priors, where, centre_xy, eye):
    """The 3-D test takes only what lies on the building: a drum against it is found, masked, named and
    placed as well as one in the open."""
    drum = placed(DRUM, *centre_xy)
    frame, rendered = render(site, [drum], look_at(eye, (*centre_xy, 0.5)))
    detector = GeometricDetector(site, priors)
    [detection] = detector.detect(frame)
    truth = rendered.labels == 0
    assert detection.family == DRUM
    assert (detection.mask & truth).sum() >= 0.9 * truth.sum()
    assert np.linalg.norm(detection.pose[:2, 3] - np.asarray(centre_xy)) < 0.01
    [located] = locate_detections(frame, site, detector)
    assert len(located.points_world) >= 300  # of at most 600 corners + 300 mask pixels
