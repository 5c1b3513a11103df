"""open_recording decides what a path holds (a bag, a scan, camera frames), subsamples it, and says what its
source dropped and warned about through the declared Recording protocol."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.sources import (Cloud, Recording, RecordingKind, SourceError, as_recording, is_rosbag, open_recording,
                             open_source)
from bim2rdt.sources.recording import BAG_SUFFIXES, SCAN_SUFFIXES, FrameRecording


def _scan_pcd(path, points: np.ndarray) -> None:
    import pypcd4

    pypcd4.PointCloud.from_xyz_points(points.astype(np.float32)).save(path)


def test_an_unorganised_pcd_is_a_scan_read_whole(tmp_path):
    points = np.random.default_rng(1).uniform(-3, 3, size=(500, 3))
    _scan_pcd(tmp_path / "laser.pcd", points)
    recording = open_recording(tmp_path / "laser.pcd")
    assert recording.kind is RecordingKind.SCAN and recording.expected_frames == 1
    [cloud] = list(recording)
    assert isinstance(cloud, Cloud) and np.allclose(cloud.points, points, atol=1e-5)
    assert recording.dropped == [] and recording.warnings == []


def test_the_real_office1_frame_is_frames_and_its_points_as_a_pcd_scan_are_a_scan(sensors, tmp_path):
    recording = open_recording(sensors / "pcl" / "office1.pcd")
    assert recording.kind is RecordingKind.FRAMES
    [frame] = list(recording)
    valid = frame.valid_depth
    v, u = np.nonzero(valid)
    points = frame.intrinsics.backproject(np.stack([u, v], axis=1).astype(float), frame.depth[valid].astype(float))
    _scan_pcd(tmp_path / "office1_scan.pcd", points)
    scan = open_recording(tmp_path / "office1_scan.pcd")
    assert scan.kind is RecordingKind.SCAN and len(next(iter(scan)).points) == len(points)


def test_a_scan_in_millimetres_is_read_with_its_depth_scale(tmp_path):
    points = np.random.default_rng(2).uniform(-3, 3, size=(400, 3))
    _scan_pcd(tmp_path / "mm.pcd", points * 1000)
    with pytest.raises(SourceError, match="millimetres.*depth-scale 1000"):
        open_recording(tmp_path / "mm.pcd")
    [cloud] = list(open_recording(tmp_path / "mm.pcd", depth_scale=1000))
    assert np.allclose(cloud.points, points, atol=1e-3)


def test_a_scan_refuses_camera_options_and_topics(tmp_path):
    _scan_pcd(tmp_path / "s.pcd", np.random.default_rng(3).uniform(-3, 3, size=(100, 3)))
    with pytest.raises(SourceError, match="a scan takes no intrinsics"):
        open_recording(tmp_path / "s.pcd", intrinsics={"fx": 1, "fy": 1, "cx": 0, "cy": 0})
    with pytest.raises(SourceError, match="topics .* are for ROS bags"):
        open_recording(tmp_path / "s.pcd", topics="depth=/d")


def test_frames_are_subsampled_every_nth_up_to_the_limit(sensors):
    grabber = sensors / "pcl" / "grabber"  # three real frames
    every_frame = [f.source for f in open_recording(grabber)]
    assert len(every_frame) == 3
    assert [f.source for f in open_recording(grabber, every=2)] == every_frame[::2]
    assert [f.source for f in open_recording(grabber, every=2, max_frames=1)] == every_frame[:1]
    assert [f.source for f in open_recording(grabber, max_frames=2)] == every_frame[:2]
    assert list(FrameRecording(list(range(10)), every=3, max_frames=2)) == [0, 3]


def test_one_rule_says_what_a_bag_is(tmp_path):
    for suffix in BAG_SUFFIXES:
        assert is_rosbag(tmp_path / f"x{suffix}")
    (tmp_path / "with_metadata").mkdir()
    (tmp_path / "with_metadata" / "metadata.yaml").write_text("x")
    (tmp_path / "storage_only").mkdir()
    (tmp_path / "storage_only" / "run_0.mcap").write_bytes(b"")
    (tmp_path / "plain").mkdir()
    assert is_rosbag(tmp_path / "with_metadata") and is_rosbag(tmp_path / "storage_only")
    assert not is_rosbag(tmp_path / "plain") and not is_rosbag(tmp_path / "x.pcd")


def test_a_rosbag2_folder_without_metadata_is_opened_as_a_bag_and_says_what_to_do(tmp_path):
    pytest.importorskip("rosbags")
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "run_0.mcap").write_bytes(b"")
    with pytest.raises(SourceError, match="without metadata.yaml: open its storage file run_0.mcap"):
        open_recording(tmp_path / "run")


def test_topics_on_a_camera_recording_are_refused_naming_the_option(sensors):
    with pytest.raises(SourceError, match=r"topics \(verify --topics\) are for ROS bags"):
        open_recording(sensors / "tum", topics="depth=/d")


def test_an_unknown_extension_names_every_reader_scans_included(tmp_path):
    (tmp_path / "notes.txt").write_text("hello")
    with pytest.raises(SourceError) as error:
        open_recording(tmp_path / "notes.txt")
    message = str(error.value)
    assert "\n" not in message and "no reader for '.txt' files" in message
    for suffix in (".pcd", ".mkv", *BAG_SUFFIXES, *SCAN_SUFFIXES):
        assert suffix in message, suffix
    assert "unorganised .pcd" in message and "TUM" in message


def test_every_recording_kind_is_a_recording_and_a_list_becomes_one(sensors, tmp_path):
    _scan_pcd(tmp_path / "s.pcd", np.random.default_rng(4).uniform(-3, 3, size=(100, 3)))
    for recording in (open_recording(sensors / "pcl" / "office1.pcd"), open_recording(tmp_path / "s.pcd")):
        assert isinstance(recording, Recording)
    listed = as_recording([1, 2, 3])
    assert isinstance(listed, Recording) and listed.expected_frames == 3 and list(listed) == [1, 2, 3]
    assert listed.dropped == [] and listed.warnings == []
    bare = open_source(sensors / "pcl" / "office1.pcd")
    assert not isinstance(bare, Recording) and isinstance(as_recording(bare), Recording)
