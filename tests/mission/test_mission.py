"""The mission's pure parts: station planning, pose deltas, association of detections to BIM elements."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.mission import MissionConfig, Target, plan_stations, pose_delta
from bim2rdt.mission.association import associate
from bim2rdt.perception.detection import Detection
from bim2rdt.registration.so3 import axis_angle
from bim2rdt.sim.meshes import mesh_for_family


def pose(x, y, yaw_deg=0.0, tilt_deg=0.0):
    T = np.eye(4)
    T[:3, :3] = axis_angle(np.array([1.0, 0, 0]), np.array(np.deg2rad(tilt_deg))) @ axis_angle(
        np.array([0, 0, 1.0]), np.array(np.deg2rad(yaw_deg)))
    T[:3, 3] = (x, y, 0.0)
    return T


def target(gid, family, x, y, yaw=0.0):
    return Target(gid, family, pose(x, y, yaw), mesh_for_family(family))


def test_a_beam_is_seen_across_its_length_not_end_on():
    beam = target("b", "Steel_I-Beam_W12x26_A992", 0.0, 0.0, yaw=0.0)  # long axis along world x
    cone = target("c", "Traffic_Cone_Orange_70cm", 10.0, 0.0)  # would put an end-on camera on the +x side
    stations = plan_stations([beam, cone], (0.0, -5.0), MissionConfig())
    beam_station = min(stations, key=lambda T: np.linalg.norm(T[:2, 3]))
    view = beam_station[:2, 3] / np.linalg.norm(beam_station[:2, 3])
    assert abs(view[0]) < np.cos(np.deg2rad(45.0))  # within 45 degrees of broadside
    assert np.linalg.norm(beam_station[:2, 3]) >= 1.2 * 3.0 - 1e-9  # far enough back for 3 m of beam


def test_stations_are_visited_nearest_first_from_the_start():
    targets = [target(str(i), "Traffic_Cone_Orange_70cm", x, 0.0) for i, x in enumerate((9.0, 1.0, 5.0))]
    stations = plan_stations(targets, (0.0, 0.0), MissionConfig())
    here = np.zeros(2)
    for k, T in enumerate(stations):
        remaining = [np.linalg.norm(S[:2, 3] - here) for S in stations[k:]]
        assert remaining[0] == min(remaining)
        here = T[:2, 3]


def test_pose_delta_reports_shift_wrapped_yaw_and_tilt():
    shift, yaw, tilt = pose_delta(pose(1.0, 1.0, yaw_deg=170.0), pose(1.3, 1.4, yaw_deg=-170.0, tilt_deg=7.0))
    assert shift == pytest.approx(0.5)
    assert yaw == pytest.approx(20.0, abs=0.5)
    assert tilt == pytest.approx(7.0)


def test_a_detection_far_from_every_element_of_its_family_is_a_new_object():
    cones = [target("near", "Traffic_Cone_Orange_70cm", 0.0, 0.0), target("far", "Traffic_Cone_Orange_70cm", 9, 9)]
    points = np.random.default_rng(0).normal([4.0, 0.0, 0.3], 0.05, (50, 3))
    claimed: set[str] = set()
    assert associate(Detection("Traffic_Cone_Orange_70cm", points, 0), cones, claimed, MissionConfig()) is None
    close = points - [3.5, 0.0, 0.0]
    found = associate(Detection("Traffic_Cone_Orange_70cm", close, 0), cones, claimed, MissionConfig())
    assert found.global_id == "near" and claimed == {"near"}
    assert associate(Detection("Traffic_Cone_Orange_70cm", close, 0), cones, claimed, MissionConfig()) is None
