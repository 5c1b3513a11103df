"""Frame: what real data carries (time, IMU up, a prior or absent pose) while the simulator's calls keep working."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.perception import EdgeFilter, Frame, GeometricDetector, Intrinsics, PerceptionError
from bim2rdt.perception.points import detection_points

RGB = np.zeros((480, 640, 3), np.uint8)
DEPTH = np.full((480, 640), 2.0, np.float32)


def test_a_frame_built_positionally_like_the_simulator_has_a_known_pose():
    pose = np.eye(4)
    pose[:3, 3] = (1.0, 2.0, 1.5)
    frame = Frame(RGB, DEPTH, Intrinsics(), pose)
    assert frame.has_pose and not frame.pose_is_prior
    assert np.array_equal(frame.require_pose(), pose)
    assert frame.time is None and frame.up is None and frame.source is None


def test_a_frame_without_a_pose_refuses_in_one_line_where_a_pose_is_needed():
    frame = Frame(RGB, DEPTH, Intrinsics(), source="office1.pcd")
    assert frame.T_world_camera is None and not frame.has_pose
    with pytest.raises(PerceptionError, match=r"^frame office1.pcd: perception needs the camera's pose") as error:
        frame.require_pose("perception")
    assert "\n" not in str(error.value)


def test_the_geometric_detector_refuses_a_frame_that_is_not_localized(site_model):
    frame = Frame(RGB, DEPTH, Intrinsics())
    with pytest.raises(PerceptionError, match="geometric detector needs the camera's pose"):
        GeometricDetector(site_model).detect(frame)


def test_back_projection_refuses_a_frame_that_is_not_localized():
    from bim2rdt.perception import Detection

    checks = ((np.indices((480, 640)).sum(axis=0) // 16) % 2 * 255).astype(np.uint8)
    frame = Frame(np.repeat(checks[..., None], 3, axis=2), DEPTH, Intrinsics())
    detection = Detection("box", label="box", bbox=(100, 100, 200, 200))
    with pytest.raises(PerceptionError, match="needs the camera's pose"):
        detection_points(frame, DEPTH, detection, None, 0.0, 0.05, EdgeFilter())


def test_a_prior_pose_becomes_known_when_localized_and_the_rest_is_kept():
    prior = np.eye(4)
    fixed = np.eye(4)
    fixed[:3, 3] = (0.1, 0.0, 0.0)
    frame = Frame(RGB, DEPTH, Intrinsics(), prior, pose_is_prior=True, time=12.5, up=(0, -2.0, 0), source="a")
    assert not frame.has_pose and np.array_equal(frame.require_pose(), prior)
    done = frame.localized(fixed)
    assert done.has_pose and np.array_equal(done.T_world_camera, fixed)
    assert done.time == 12.5 and np.allclose(done.up, (0, -1, 0)) and done.source == "a"
    assert frame.pose_is_prior and np.array_equal(frame.T_world_camera, prior)


@pytest.mark.parametrize("up, match", [((0, 0, 0), "non-zero"), ((1, 0), "3-vector"), ((np.nan, 0, 1), "finite"),
                                       (("a", "b", "c"), "numbers")])
def test_an_up_that_is_not_a_direction_is_refused(up, match):
    with pytest.raises(PerceptionError, match=match):
        Frame(RGB, DEPTH, Intrinsics(), up=up)


def test_non_numeric_depth_a_prior_flag_without_a_pose_and_a_bad_time_are_refused():
    with pytest.raises(PerceptionError, match="depth must be numeric"):
        Frame(RGB, DEPTH.astype(str), Intrinsics())
    with pytest.raises(PerceptionError, match="depth must be numeric"):
        Frame(RGB, DEPTH > 0, Intrinsics())
    with pytest.raises(PerceptionError, match="pose_is_prior is set but there is no T_world_camera"):
        Frame(RGB, DEPTH, Intrinsics(), pose_is_prior=True)
    with pytest.raises(PerceptionError, match="time must be seconds"):
        Frame(RGB, DEPTH, Intrinsics(), time="noon")
