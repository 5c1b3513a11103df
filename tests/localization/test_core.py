"""One core for both localizers: the real office1 frame fixed by ``localize`` (its depth grid) and by
``localize_cloud`` (its points) lands in the same place; refusals carry their kind; one depth-to-points helper;
a caller's OccludedMap is used as it is."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.localization import (LocalizationConfig, LocalizationError, OccludedMap, Refusal, depth_points, localize,
                                  localize_cloud)

from loc_helpers import errors, offset

REAL_SENSOR = LocalizationConfig(inlier_distance=0.05, huber_delta=0.025, min_inlier_fraction=0.3)


def test_depth_points_are_every_valid_pixel_back_projected(office1):
    frame = office1.frame
    valid = frame.valid_depth
    v, u = np.nonzero(valid)
    expected = frame.intrinsics.backproject(np.stack([u, v], axis=1).astype(float), frame.depth[valid].astype(float))
    points = depth_points(frame)
    assert points.shape == expected.shape and np.allclose(points, expected)
    near = depth_points(frame, 2, 1.0, 3.0)
    assert 0 < len(near) < len(points) / 4 and np.all((near[:, 2] >= 1.0) & (near[:, 2] <= 3.0))


def test_the_frame_and_its_cloud_are_fixed_by_one_core(office1):
    """Both fixes are judged alike (the same fields, the correction measured from the same prior). The cloud's
    map hides what lies behind the model's furniture, the frame's does not: office1's frame slides ~25 cm along
    x onto the wardrobe's front (cloud.py's note), its cloud does not; the yaw is right in both."""
    T_true, prior = office1.T_world_camera, offset(office1.T_world_camera, 0.14, 0.14, 5.0)
    frame_fix = localize(office1.frame, office1.model, prior, config=REAL_SENSOR)
    cloud_fix = localize_cloud(depth_points(office1.frame), office1.model, prior, config=REAL_SENSOR)
    for fix in (frame_fix, cloud_fix):
        assert abs(errors(fix.pose, T_true)[1]) < 1.0 and fix.residual < REAL_SENSOR.inlier_distance
        assert np.array_equal(fix.prior, prior)
        assert fix.moved == pytest.approx(np.linalg.norm(fix.pose[:3, 3] - prior[:3, 3]))
        assert fix.covariance.shape == fix.information.shape == (6, 6)
    assert np.linalg.norm(errors(cloud_fix.pose, T_true)[0]) < 0.05


def test_a_prior_in_the_wrong_room_is_refused_with_its_kind_by_both(office1):
    far = office1.T_world_camera.copy()
    far[2, 3] += 30.0  # thirty metres above the office: nothing of the BIM within the basin
    with pytest.raises(LocalizationError, match="the frame sees no permanent element") as frame_error:
        localize(office1.frame, office1.model, far, config=REAL_SENSOR)
    with pytest.raises(LocalizationError, match="the cloud sees no permanent element") as cloud_error:
        localize_cloud(depth_points(office1.frame), office1.model, far, config=REAL_SENSOR)
    assert frame_error.value.kind is cloud_error.value.kind is Refusal.NO_PERMANENT_IN_VIEW


def test_a_bad_prior_is_bad_input():
    with pytest.raises(LocalizationError, match="not rigid") as error:
        localize_cloud(np.ones((10, 3)), None, np.diag([2.0, 1, 1, 1]))
    assert error.value.kind is Refusal.BAD_INPUT


def test_a_callers_occluded_map_is_used_as_it_is(office1, monkeypatch):
    scene = OccludedMap.of(office1.model)
    monkeypatch.setattr(OccludedMap, "of", classmethod(lambda cls, model: pytest.fail("built again")))
    fix = localize_cloud(depth_points(office1.frame), office1.model, offset(office1.T_world_camera, 0.1, 0.0, 2.0),
                         config=REAL_SENSOR, scene=scene)
    assert np.linalg.norm(errors(fix.pose, office1.T_world_camera)[0]) < 0.05
