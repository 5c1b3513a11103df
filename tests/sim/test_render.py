"""The RGB-D simulator: ray casting sees the nearest surface (real occlusion), depth is z in the camera frame."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from bim2rdt.perception.camera import Intrinsics, look_at
from bim2rdt.sim.render import add_sensor_noise, cast_frame, depth_sigma
from bim2rdt.sim.scene import GROUND, MISS, PlacedObject, SiteScene

SMALL = Intrinsics(width=160, height=120, fx=130.0, fy=130.0, cx=79.5, cy=59.5)


def _at(x: float, y: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = (x, y, 0.0)
    return T


def _two_boxes() -> SiteScene:
    box = trimesh.creation.box(extents=(0.5, 0.5, 1.0), transform=trimesh.transformations.translation_matrix(
        (0.0, 0.0, 0.5)))
    return SiteScene([PlacedObject("front", box, _at(0.0, 0.0)), PlacedObject("behind", box, _at(0.0, 2.0))])


def test_an_object_behind_another_is_hidden_and_depth_is_the_front_face():
    camera = look_at((0.0, -3.0, 0.5), (0.0, 0.0, 0.5))
    frame = cast_frame(_two_boxes(), SMALL, camera)
    centre = frame.labels[60, 80]
    assert centre == 0
    assert frame.depth[60, 80] == pytest.approx(3.0 - 0.25, abs=1e-6)
    assert not np.any(frame.labels == 1)  # same footprint straight behind: fully occluded


def test_ground_and_sky_are_labelled():
    frame = cast_frame(_two_boxes(), SMALL, look_at((0.0, -3.0, 1.5), (0.0, 0.0, 0.5)))
    assert frame.labels[-1, 80] == GROUND
    assert frame.labels[0, 80] == MISS and np.isnan(frame.depth[0, 80])


def test_sensor_noise_matches_the_depth_model():
    frame = cast_frame(_two_boxes(), SMALL, look_at((0.0, -3.0, 0.5), (0.0, 0.0, 0.5)))
    noisy = add_sensor_noise(frame, np.random.default_rng(0))
    face = frame.labels == 0
    errors = (noisy.depth - frame.depth)[face]
    assert np.std(errors) == pytest.approx(depth_sigma(2.75), rel=0.15)
