"""PCL grabber TIFFs (SOURCES.md): three Kinect frames in millimetres, intrinsics from the .xml, a camera looking
down at the carpet from a plausible height."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from floor_fit import camera_points, fit_plane

from bim2rdt.sources import SourceError, open_source


@pytest.fixture(scope="module")
def frames(sensors):
    return list(open_source(sensors / "pcl" / "grabber"))


def test_the_three_frames_read_in_time_order_with_the_xml_intrinsics(frames):
    assert len(frames) == 3
    assert [round(f.time - frames[0].time, 3) for f in frames] == [0.0, 0.254, 0.518]  # from the file names
    for frame in frames:
        k = frame.intrinsics
        assert (k.width, k.height, k.fx, k.fy, k.cx, k.cy) == (640, 480, 525, 525, 320, 240)  # the .xml
        depth = frame.depth[frame.valid_depth]
        assert 0.65 < depth.min() and depth.max() < 1.8  # SOURCES.md: scene 0.71-1.7 m
        assert frame.rgb.dtype == np.uint8 and frame.rgb.std() > 10


def test_the_camera_looks_down_at_the_carpet_from_a_plausible_height(frames):
    # the carpet is most of the view; a Kinect held or mounted over it stands 0.5-1.0 m above it
    # (millimetres read as metres would put it 1000x higher; a 5000/m scale 5x lower)
    normal, height, share = fit_plane(camera_points(frames[0]), tolerance=0.015)
    assert share > 0.4 and normal[1] < -0.5  # it faces up in the image (against y, down)
    assert 0.5 < height < 1.0, height
    tilt = np.degrees(np.arccos(-normal[1]))
    assert 20 < tilt < 70  # looking down at it, not along it


def test_a_grabber_folder_without_xml_needs_the_depth_scale_and_intrinsics(tmp_path, sensors):
    folder = tmp_path / "grab"
    folder.mkdir()
    for name in ("frame_20121214T142255.814212_depth.tiff", "frame_20121214T142255.814212_rgb.tiff"):
        shutil.copy(sensors / "pcl" / "grabber" / name, folder / name)
    with pytest.raises(SourceError, match=r"_depth.tiff: the depth's units are unknown .*give depth_scale"):
        list(open_source(folder))
    with pytest.raises(SourceError, match=r"_depth.tiff: no camera intrinsics in the recording"):
        list(open_source(folder, depth_scale=1000))
    [frame] = list(open_source(folder, depth_scale=1000, intrinsics=dict(fx=525, fy=525, cx=320, cy=240)))
    assert frame.intrinsics.cx == 320


def test_an_empty_folder_has_no_frames(tmp_path):
    with pytest.raises(SourceError, match=r"empty: no frames here"):
        (tmp_path / "empty").mkdir() or open_source(tmp_path / "empty")
