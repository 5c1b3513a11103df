"""Tracking a recording without poses through verify: the PCL grabber frames, written as a folder of organised .pcd
frames, tracked from a user prior by frame-to-frame odometry; a simulated sweep with no prior at all found globally
on the BIM, then tracked, and found globally again after two refused frames in a row."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from bim2rdt.localization.cloud import scan_points
from bim2rdt.localization.gravity import CAMERA_UP, level
from bim2rdt.localization.odometry import icp_odometry
from bim2rdt.localization.planar import from_planar, to_planar
from bim2rdt.sim.tour import render_frame, tour_poses, tour_scene
from bim2rdt.sources import open_source
from bim2rdt.sources.pcd_folder import write_organised_pcd
from bim2rdt.verify import VerifyConfig, prior_pose, verify_frames
from bim2rdt.localization import depth_points
from bim2rdt.verify.chain import real_sensor_localization

FAST = VerifyConfig(find_new=False)


@pytest.fixture(scope="module")
def grabber_folder(sensors, tmp_path_factory):
    """The three grabber frames as organised .pcd files (what PCL's grabber writes with its PCD option)."""
    folder = tmp_path_factory.mktemp("grabber-pcd")
    for frame in open_source(sensors / "pcl" / "grabber"):
        write_organised_pcd(frame, folder / frame.source.replace("_depth.tiff", ".pcd"))
    return folder


def test_the_grabber_frames_as_a_pcd_folder_are_tracked_by_odometry_from_the_first_fix(grabber_folder, site_model):
    frames = open_source(grabber_folder)
    first = next(iter(frames))
    # the camera looks down at a carpet: its height and tilt from the floor, its place on the site's slab given
    floor = level(scan_points(depth_points(first), real_sensor_localization()), None, "", CAMERA_UP, 60, 40)
    prior = prior_pose((10.0, 7.0, floor.height), 30.0, floor.up)
    result = verify_frames(frames, site_model, prior, FAST)
    assert [f.prior_source for f in result.frames] == ["user", "tracked", "tracked"]
    assert all(f.accepted for f in result.frames), [f.reason for f in result.frames]
    clouds = [depth_points(f) for f in frames]
    for k in (1, 2):
        step = icp_odometry(clouds[k - 1], clouds[k])
        assert step.fitness > 0.8
        expected = result.frames[k - 1].pose @ step.T_previous_current
        assert np.allclose(result.frames[k].prior, expected, atol=1e-6)  # last fix composed with the odometry
        moved = np.linalg.norm(step.T_previous_current[:3, 3])
        assert 0.002 < moved < 0.02  # a handheld Kinect 0.25 s apart: millimetres, not nothing and not a jump
    entry = result.frames[1].to_dict()
    assert entry["prior_source"] == "tracked" and "candidates" not in entry


@pytest.fixture(scope="module")
def sweep(site_model):
    """Four frames near the tour's second station (unique view), 8 cm and 2 degrees apart, then two
    blank ones (the sensor covered), then the first again; and their true poses."""
    scene = tour_scene(site_model, seed=0)
    state, tilt = to_planar(tour_poses(10.0)[1])
    poses = [from_planar(state + np.array([0.08 * k, 0.0, 0.0, np.deg2rad(2.0 * k)]), tilt) for k in range(3)]
    frames = [replace(render_frame(scene.scene, T, np.random.default_rng(k)), T_world_camera=None)  # no poses
              for k, T in enumerate(poses)]
    blank = replace(frames[2], depth=np.zeros_like(frames[2].depth))
    return frames + [blank, blank, frames[0]], poses + [poses[2], poses[2], poses[0]]


def test_a_sweep_without_a_prior_is_found_then_tracked_then_found_again_after_two_refusals(site_model, sweep):
    frames, truth = sweep
    result = verify_frames(frames, site_model, None, FAST)
    assert [f.prior_source for f in result.frames] == ["global", "tracked", "tracked", "tracked", "tracked", "global"]
    assert [f.accepted for f in result.frames] == [True, True, True, False, False, True]
    for f in result.frames:
        if f.accepted:
            a, _ = to_planar(f.pose)
            b, _ = to_planar(truth[f.index])
            assert np.linalg.norm(a[:3] - b[:3]) < 0.05 and abs(np.rad2deg(a[3] - b[3])) < 1.0
    assert result.frames[0].candidates and result.frames[0].to_dict()["candidates"][0]["refined"]


@pytest.fixture(scope="module")
def unaligned(site_model):
    """The tour's corner (ambiguous alone) then the next station, each frame carrying its pose in a robot's odometry
    frame a random 4-DoF offset from the BIM's, the second 2 % of the leg and 0.6 degree off (drift); and the
    true poses."""
    scene = tour_scene(site_model, seed=0)
    poses = tour_poses(10.0)[:2]
    rng = np.random.default_rng(32)
    T_odom_world = from_planar(np.r_[rng.uniform(-50, 50, 2), 0.4, rng.uniform(-np.pi, np.pi)], np.eye(3))
    state, tilt = to_planar(poses[1])
    drifted = from_planar(state + np.array([0.1, -0.08, 0.0, np.deg2rad(0.6)]), tilt)
    own = [T_odom_world @ poses[0], T_odom_world @ drifted]
    frames = [replace(render_frame(scene.scene, T, np.random.default_rng(k)), T_world_camera=own[k])
              for k, T in enumerate(poses)]
    return frames, poses


def test_own_poses_as_odometry_find_the_first_frame_on_the_bim_and_carry_its_places_through_the_sweep(
        site_model, unaligned):
    frames, truth = unaligned
    result = verify_frames(frames, site_model, None, FAST, own_poses="odometry")
    assert [f.index for f in result.frames] == [0, 1]
    assert [f.prior_source for f in result.frames] == ["global", "global"]
    assert [f.resolved_at for f in result.frames] == [1, 1] and [f.places for f in result.frames] == [1, 1]
    for f in result.frames:
        assert f.accepted, f.reason
        a, _ = to_planar(f.pose)
        b, _ = to_planar(truth[f.index])
        assert np.linalg.norm(a[:3] - b[:3]) < 0.05 and abs(np.rad2deg(a[3] - b[3])) < 1.0
    entry = result.frames[0].to_dict()
    assert entry["resolved_at"] == 1 and entry["places"] == 1


def test_by_default_own_poses_are_taken_in_the_models_frame_as_before(site_model, unaligned):
    frames, _ = unaligned
    result = verify_frames(frames[:1], site_model, None, FAST)
    [first] = result.frames
    assert first.prior_source == "source" and np.allclose(first.prior, frames[0].T_world_camera)
    assert not first.accepted and first.places is None and "places" not in first.to_dict()
