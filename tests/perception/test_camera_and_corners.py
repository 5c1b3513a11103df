"""Pinhole camera geometry and Shi-Tomasi corners."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.perception.camera import CameraError, Intrinsics, look_at
from bim2rdt.perception.corners import shi_tomasi


def test_look_at_points_the_optical_axis_at_the_target_with_image_down_along_world_down():
    T = look_at((0.0, -2.0, 1.0), (0.0, 0.0, 1.0))
    assert np.allclose(T[:3, 2], (0.0, 1.0, 0.0))
    assert np.allclose(T[:3, 1], (0.0, 0.0, -1.0))
    assert np.isclose(np.linalg.det(T[:3, :3]), 1.0)


def test_backprojecting_a_pixel_ray_at_its_depth_returns_the_ray_point():
    intrinsics = Intrinsics()
    rays = intrinsics.pixel_rays()
    uv = np.array([[10.0, 20.0], [600.0, 400.0]])
    points = intrinsics.backproject(uv, np.array([2.0, 3.5]))
    assert np.allclose(points[0], rays[20, 10] * 2.0) and np.allclose(points[1], rays[400, 600] * 3.5)


def test_shi_tomasi_finds_the_four_corners_of_a_square_inside_the_roi_only():
    image = np.zeros((100, 100), dtype=np.uint8)
    image[30:60, 30:60] = 255
    image[80:90, 5:15] = 255  # outside the ROI
    corners = shi_tomasi(image, (20, 20, 70, 70), max_corners=10)
    assert len(corners) == 4
    for expected in ((30, 30), (59, 30), (30, 59), (59, 59)):
        assert np.min(np.linalg.norm(corners - expected, axis=1)) < 1.5


@pytest.mark.parametrize("eye, target, message", [
    ((0.0, 0.0, 2.0), (0.0, 0.0, 0.0), "parallel to up"),
    ((1.0, 1.0, 1.0), (1.0, 1.0, 1.0), "eye and target coincide"),
])
def test_look_at_refuses_a_view_whose_image_axes_are_undefined(eye, target, message):
    with pytest.raises(CameraError, match=message):
        look_at(eye, target)


@pytest.mark.parametrize(("field", "value", "reason"), [
    ("fx", 0.0, "fx must be positive"), ("fy", -525.0, "fy must be positive"),
    ("fx", float("nan"), "fx must be a finite number"), ("fy", float("inf"), "fy must be a finite number"),
    ("cx", float("nan"), "cx must be a finite number"), ("cy", "239.5", "cy must be a finite number"),
    ("width", 0, "width must be a positive whole number"), ("height", 480.5, "height must be a positive whole"),
])
def test_intrinsics_no_camera_has_are_refused_where_they_are_made(field, value, reason):
    with pytest.raises(CameraError, match=f"intrinsics: {reason}"):
        Intrinsics(**{field: value})


def test_intrinsics_a_camera_has_are_taken_as_given():
    camera = Intrinsics(width=np.int64(160), height=120, fx=np.float32(130.0), fy=130, cx=79.5, cy=59.5)
    assert camera.fx == 130.0 and camera.width == 160
