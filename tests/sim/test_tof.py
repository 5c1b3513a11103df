"""Time-of-flight artefacts of the simulated camera: mixed pixels at depth steps, dropouts, workers in view."""

from __future__ import annotations

import numpy as np
import trimesh

from bim2rdt.perception.camera import Intrinsics, look_at
from bim2rdt.sim.meshes import worker
from bim2rdt.sim.render import add_sensor_noise, cast_frame
from bim2rdt.sim.scene import PlacedObject, SiteScene
from bim2rdt.sim.tof import TofEffects, dropout_chance, mixed_depth
from bim2rdt.sim.workers import CLEARANCE, worker_in_view

SMALL = Intrinsics(width=160, height=120, fx=130.0, fy=130.0, cx=79.5, cy=59.5)


def _wall_behind_box() -> SiteScene:
    """A 1 m box 3 m ahead of the camera, turned 20 degrees (its outline crosses pixels, as outlines do), and a
    wall 5.5 m ahead behind it (no ground)."""
    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0)).apply_transform(
        trimesh.transformations.rotation_matrix(np.deg2rad(20.0), (0.0, 0.0, 1.0)))
    wall = trimesh.creation.box(extents=(10.0, 0.1, 10.0))
    at = lambda y: trimesh.transformations.translation_matrix((0.0, y, 0.0))  # noqa: E731
    return SiteScene([PlacedObject("box", box, at(3.0)), PlacedObject("wall", wall, at(5.55))], ground_size=0.0)


def test_pixels_on_a_depth_step_report_a_depth_between_the_two_surfaces():
    camera = look_at((0.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    clean = cast_frame(_wall_behind_box(), SMALL, camera)
    mixed = cast_frame(_wall_behind_box(), SMALL, camera, TofEffects(dropouts=False))
    between = (mixed.depth > np.nanmax(clean.depth[clean.labels == 0]) + 0.05) & (mixed.depth < 5.5 - 0.05)
    assert 20 < np.count_nonzero(between) < 300  # a fringe around the box's silhouette, not the whole image
    changed = np.abs(mixed.depth - clean.depth) > 0.02
    labels = clean.labels
    edge = np.zeros(labels.shape, dtype=bool)
    edge[:, 1:] |= labels[:, 1:] != labels[:, :-1]
    edge[:, :-1] |= labels[:, 1:] != labels[:, :-1]
    edge[1:] |= labels[1:] != labels[:-1]
    edge[:-1] |= labels[1:] != labels[:-1]
    assert not (changed & ~edge).any()  # only pixels on the outline mix
    assert np.allclose(mixed.depth[55:65, 75:85], clean.depth[55:65, 75:85])  # the faces themselves are untouched


def test_mixed_depth_weighs_returns_by_amplitude_and_ignores_misses():
    depths = np.array([[3.0], [3.0], [5.0], [np.nan]])
    assert np.isclose(mixed_depth(depths, np.array([[1.0], [1.0], [2.0], [9.0]]))[0], 4.0)
    assert np.isnan(mixed_depth(np.full((4, 1), np.nan), np.ones((4, 1))))[0]


def test_dropouts_take_grazing_and_dark_far_returns():
    effects = TofEffects()
    chance = dropout_chance(np.cos(np.deg2rad([10.0, 80.0, 89.0, 10.0])), np.array([0.05, 0.05, 0.05, 0.001]),
                            effects)
    assert chance[0] == 0.0 and 0.0 < chance[1] < 1.0 and chance[2] == 1.0 and chance[3] == 1.0
    camera = look_at((0.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    frame = cast_frame(_wall_behind_box(), SMALL, camera, TofEffects(flying_pixels=False))
    noisy = add_sensor_noise(frame, np.random.default_rng(0))
    assert np.isnan(noisy.depth).sum() >= np.isnan(frame.depth).sum()
    assert frame.dropout is not None and frame.dropout.shape == frame.depth.shape


def test_a_worker_is_person_sized_and_stands_in_view_clear_of_objects():
    mesh = worker()
    assert 1.7 < mesh.extents[2] < 1.85 and 0.4 < max(mesh.extents[:2]) < 0.7
    camera = look_at((0.0, 0.0, 1.1), (0.0, 4.0, 0.5))
    rng = np.random.default_rng(3)
    for _ in range(20):
        person = worker_in_view(camera, rng, keep_clear_xy=[np.array([0.0, 3.0])])
        xy = person.T_world_model[:2, 3]
        assert 1.2 <= np.linalg.norm(xy) <= 4.5 and abs(np.degrees(np.arctan2(xy[0], xy[1]))) <= 25.0
        assert np.linalg.norm(xy - (0.0, 3.0)) >= CLEARANCE
