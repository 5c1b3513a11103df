"""The Azure Kinect recording (SOURCES.md): depth in metres, intrinsics from its attached calibration, colour
registered onto depth, and an IMU up that agrees with the horizontal surface seen in the depth."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from bim2rdt.sources import SourceError, open_source

pytest.importorskip("av", reason="the sensors extra (PyAV) is not installed")
from floor_fit import camera_points, fit_plane  # noqa: E402


@pytest.fixture(scope="module")
def recording(sensors):
    return sensors / "azure_kinect" / "recording.mkv"


@pytest.fixture(scope="module")
def frames(recording):
    return list(open_source(recording))


def test_the_recording_decodes_to_depth_frames_in_metres(frames):
    assert len(frames) >= 1
    frame = frames[0]
    assert frame.depth.shape == (576, 640) and frame.rgb.shape == (576, 640, 3)
    depth = frame.depth[frame.valid_depth]
    assert 0.15 < np.percentile(depth, 5) < 0.35 and 1.8 < np.percentile(depth, 95) < 2.4  # SOURCES.md: 0.23-2.1 m
    assert frame.valid_depth.mean() > 0.6  # SOURCES.md: 77 % valid
    assert frame.T_world_camera is None and frame.time == pytest.approx(0.800222, abs=1e-6)  # 0.464 s + offset


def test_its_intrinsics_come_from_the_attached_calibration(frames):
    k = frames[0].intrinsics
    # SOURCES.md, from the calibration with the SDK's NFOV_UNBINNED conventions
    assert (k.fx, k.fy, k.cx, k.cy) == pytest.approx((504.6, 504.7, 332.8, 348.8), abs=0.06)


def test_the_imu_up_is_within_two_degrees_of_the_desk_normal_seen_in_the_depth(frames):
    frame = frames[0]
    assert frame.up is not None
    # the desk top fills the bottom rows (the camera stands on it); its plane comes from the depth alone
    normal, height, share = fit_plane(camera_points(frame, slice(470, None)))
    assert share > 0.5
    angle = np.degrees(np.arccos(np.clip(normal @ frame.up, -1, 1)))
    assert angle < 2.0, f"IMU up is {angle:.2f} degrees from the desk's normal"


def test_colour_is_registered_onto_depth(frames):
    frame = frames[0]
    coloured = frame.rgb.any(axis=2)
    assert (coloured & frame.valid_depth).mean() > 0.9 * frame.valid_depth.mean()  # depth pixels got colour
    assert not (coloured & ~frame.valid_depth).any()  # and only they did


def test_a_calibration_given_as_json_replaces_the_attached_one(recording, sensors, tmp_path):
    calibration = json.loads((sensors / "azure_kinect" / "calibration.json").read_text())
    camera = calibration["CalibrationInformation"]["Cameras"][0]
    camera["Intrinsics"]["ModelParameters"][2] *= 1.01  # fx 1 % longer
    (tmp_path / "calibration.json").write_text(json.dumps(calibration))
    [frame] = list(open_source(recording, calibration=tmp_path / "calibration.json", max_frames=1))
    assert frame.intrinsics.fx == pytest.approx(504.6 * 1.01, abs=0.1)


def test_a_file_that_is_not_a_kinect_recording_is_one_line(tmp_path, recording):
    (tmp_path / "junk.mkv").write_bytes(b"not a matroska file" * 10)
    with pytest.raises(SourceError, match=r"junk.mkv: not a readable Matroska file"):
        open_source(tmp_path / "junk.mkv")
    bad = tmp_path / "calibration.json"
    bad.write_text('{"CalibrationInformation": {"Cameras": []}}')
    with pytest.raises(SourceError, match=r"calibration.json is not an Azure Kinect calibration"):
        open_source(recording, calibration=bad)
    shutil.copy(recording, tmp_path / "copy.mkv")
    with pytest.raises(SourceError, match="unknown source option 'fps'"):
        open_source(tmp_path / "copy.mkv", fps=30)
