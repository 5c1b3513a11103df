"""office1.pcd (a real Kinect v1 frame) as a frame: intrinsics from the cloud, and the depth correction that puts
its floor on the IFC's floor. Truth: SOURCES.md and office1_truth.json, never the reader."""

from __future__ import annotations

import json

import numpy as np
import pytest

from bim2rdt.sources import SourceError, open_source


@pytest.fixture(scope="module")
def truth(sensors):
    return json.loads((sensors / "pcl" / "office1_truth.json").read_text())


def test_office1_reads_as_one_frame_with_the_kinect_intrinsics_and_no_pose(sensors):
    [frame] = list(open_source(sensors / "pcl" / "office1.pcd"))
    k = frame.intrinsics
    assert (k.width, k.height) == (640, 480)
    assert (k.fx, k.fy, k.cx, k.cy) == pytest.approx((525.0, 525.0, 320.0, 240.0), abs=0.01)  # SOURCES.md
    assert int(frame.valid_depth.sum()) == 254_456  # SOURCES.md: valid points
    assert frame.T_world_camera is None and frame.source == "office1.pcd"
    assert frame.rgb.std() > 10  # the packed colour was unpacked, not a grey stand-in


def _floor_pixels(frame, plane) -> np.ndarray:
    """Pixels whose raw point lies within 3 cm of the truth's raw floor plane (n . p = d, camera frame)."""
    points = frame.intrinsics.pixel_rays() * frame.depth[..., None]
    distance = np.abs(points @ np.array(plane["n"]) - plane["d"])
    return frame.valid_depth & (distance < 0.03)


def test_with_its_depth_correction_the_floor_lies_on_the_world_floor(sensors, truth):
    path = sensors / "pcl" / "office1.pcd"
    [raw] = list(open_source(path))
    floor = _floor_pixels(raw, truth["plane_fits"]["raw"]["floor"])
    assert floor.sum() > 10_000
    T = np.array(truth["T_world_camera"])

    def floor_heights(frame):
        points = (frame.intrinsics.pixel_rays() * frame.depth[..., None])[floor]
        return (points @ T[:3, :3].T + T[:3, 3])[:, 2]

    [corrected] = list(open_source(path, depth_correction=truth["depth_correction"]["g"]))
    z = floor_heights(corrected)
    assert abs(np.median(z)) < 0.015 and np.percentile(np.abs(z), 90) < 0.04  # truth: median 0.8, p90 2.1 cm
    warped = np.abs(floor_heights(raw))  # the raw depth is warped (the floor rolls 4.5 degrees): the correction matters
    assert np.percentile(warped, 90) > 2 * np.percentile(np.abs(z), 90)


def test_a_prior_given_as_an_option_is_a_prior(sensors, truth):
    [frame] = list(open_source(sensors / "pcl" / "office1.pcd", prior=truth["T_world_camera"]))
    assert frame.pose_is_prior and not frame.has_pose
    assert np.allclose(frame.T_world_camera, truth["T_world_camera"])


def _write_pcd(path, xyz, width, height):
    import pypcd4

    cloud = pypcd4.PointCloud.from_xyz_points(xyz.reshape(-1, 3).astype(np.float32))
    cloud.metadata = cloud.metadata.derive(width=width, height=height)
    cloud.save(path)


def test_a_millimetre_organised_cloud_is_refused_naming_the_scale(tmp_path):
    rays = np.stack([*np.meshgrid(np.arange(40) - 20.0, np.arange(30) - 15.0), np.full((30, 40), 50.0)], -1) / 50
    _write_pcd(tmp_path / "mm.pcd", rays * 2000.0, 40, 30)
    with pytest.raises(SourceError, match=r"mm.pcd: median depth 2000 m .* looks like millimetres; give depth_scale"):
        list(open_source(tmp_path / "mm.pcd"))
    [frame] = list(open_source(tmp_path / "mm.pcd", depth_scale=1000))
    assert np.allclose(frame.depth, 2.0) and frame.intrinsics.fx == pytest.approx(50.0)


def test_an_unorganised_cloud_is_not_a_frame(tmp_path):
    _write_pcd(tmp_path / "scan.pcd", np.random.default_rng(0).uniform(1, 2, (100, 3)), 100, 1)
    with pytest.raises(SourceError, match="not organised: it is a scan.* open_recording .* or read_cloud"):
        open_source(tmp_path / "scan.pcd")  # at once: a caller can choose the scan reader before iterating
