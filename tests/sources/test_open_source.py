"""open_source picks a reader from the path, checks its options once, and says in one line what is wrong."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from bim2rdt.sources import FrameSource, SourceError, open_source
from bim2rdt.sources.source import FILE_READERS


def _one_line(error) -> str:
    text = str(error.value)
    assert "\n" not in text
    return text


def test_every_reader_is_a_frame_source(sensors):
    for path in ("pcl/office1.pcd", "pcl/grabber", "tum", "azure_kinect/recording.mkv"):
        assert isinstance(open_source(sensors / path), FrameSource)


def test_a_path_that_is_absent_or_of_no_known_format_is_refused(tmp_path):
    with pytest.raises(SourceError, match=r"nowhere.bag: no such file or folder") as error:
        open_source(tmp_path / "nowhere.bag")
    _one_line(error)
    (tmp_path / "notes.txt").write_text("hello")
    with pytest.raises(SourceError, match=r"notes.txt: no frame reader for '.txt' files \(readers: .bag, .db3, .mcap, .mkv, .pcd"):
        open_source(tmp_path / "notes.txt")


def test_a_folder_without_depth_has_no_frames(tmp_path):
    import cv2

    cv2.imwrite(str(tmp_path / "only_color.png"), np.zeros((4, 4, 3), np.uint8))
    with pytest.raises(SourceError, match=r"no frames here: a folder needs a TUM rgb.txt") as error:
        open_source(tmp_path)
    _one_line(error)


def test_a_tum_folder_whose_lists_pair_nothing_has_no_frames(tmp_path):
    (tmp_path / "rgb.txt").write_text("# nothing\n")
    (tmp_path / "depth.txt").write_text("1.0 depth/1.png\n")
    with pytest.raises(SourceError, match="no frames: no colour and depth image within 20 ms"):
        open_source(tmp_path)


def test_a_pcd_without_depth_is_refused(tmp_path):
    header = "VERSION .7\nFIELDS x y\nSIZE 4 4\nTYPE F F\nCOUNT 1 1\nWIDTH 4\nHEIGHT 3\nPOINTS 12\nDATA ascii\n"
    (tmp_path / "flat.pcd").write_text(header + "0 1\n" * 12)
    with pytest.raises(SourceError, match=r"flat.pcd: the PCD has no field 'z'"):
        list(open_source(tmp_path / "flat.pcd"))


def test_an_unorganised_pcd_is_refused_as_a_frame_when_opened_not_when_read(tmp_path):
    import pypcd4

    xyz = np.random.default_rng(0).normal(size=(50, 3)).astype(np.float32)
    pypcd4.PointCloud.from_xyz_points(xyz).save(tmp_path / "scan.pcd")
    with pytest.raises(SourceError, match=r"scan.pcd: the PCD is not organised: it is a scan.*open_recording"):
        open_source(tmp_path / "scan.pcd")


@pytest.mark.parametrize("options, match", [
    (dict(depth_correction=(0.1, 0.2)), "depth_correction must be three finite numbers"),
    (dict(prior=np.eye(3)), "prior must be a finite 4x4"),
    (dict(depth_scale=-5), "depth_scale must be a positive number"),
    (dict(intrinsics=dict(fx=500)), "intrinsics needs fx, fy, cx, cy"),
    (dict(up=(0, 0, 0)), "up must be a finite non-zero"),
    (dict(max_frames=0), "max_frames must be a positive whole number"),
    (dict(colour=True), "unknown source option 'colour'"),
])
def test_bad_options_are_named(sensors, options, match):
    with pytest.raises(SourceError, match=match) as error:
        open_source(sensors / "pcl" / "office1.pcd", **options)
    assert _one_line(error).startswith(str(sensors / "pcl" / "office1.pcd"))


def test_intrinsics_of_the_wrong_size_are_refused(sensors):
    from bim2rdt.perception import Intrinsics

    with pytest.raises(SourceError, match="the intrinsics are for 1280x720 but the depth image is 640x480"):
        list(open_source(sensors / "pcl" / "office1.pcd", intrinsics=Intrinsics(1280, 720)))


def test_a_missing_optional_package_names_the_extra_to_install(sensors, monkeypatch):
    monkeypatch.setitem(sys.modules, "av", None)  # import av now raises ImportError
    with pytest.raises(SourceError, match=r"recording.mkv: reading an Azure Kinect .mkv needs the Python package "
                                          r"'av': pip install 'bim2rdt\[sensors\]'") as error:
        open_source(sensors / "azure_kinect" / "recording.mkv")
    _one_line(error)


def test_a_later_reader_plugs_in_by_extension(tmp_path, monkeypatch):
    class Bag:
        def __init__(self, path, options):
            self.path, self.options = path, options

        def __iter__(self):
            return iter(())

    module = type(sys)("fake_bag_reader")
    module.Bag = Bag
    monkeypatch.setitem(sys.modules, "fake_bag_reader", module)
    monkeypatch.setitem(FILE_READERS, ".mcap", "fake_bag_reader:Bag")
    (tmp_path / "run.mcap").write_bytes(b"")
    source = open_source(tmp_path / "run.mcap", depth_scale=1000)
    assert isinstance(source, Bag) and source.options.depth_scale == 1000.0
