"""TUM RGB-D: the real sample pair at the right scale (its floor a plausible camera height below), and a TUM
sequence folder's lists, pairing and ground-truth priors."""

from __future__ import annotations

import shutil

import cv2
import numpy as np
import pytest
from floor_fit import camera_points, fit_plane

from bim2rdt.sources import SourceError, open_source


def test_the_tum_frame_reads_in_metres_with_tum_default_intrinsics(sensors):
    [frame] = list(open_source(sensors / "tum"))
    k = frame.intrinsics
    assert (k.fx, k.fy, k.cx, k.cy) == (525.0, 525.0, 319.5, 239.5)  # SOURCES.md: TUM's default
    depth = frame.depth[frame.valid_depth]
    assert 0.78 < frame.valid_depth.mean() < 0.84  # SOURCES.md: 81 % valid
    assert 1.6 < np.percentile(depth, 5) and np.percentile(depth, 95) < 3.4  # SOURCES.md: 1.8-3.1 m


def test_the_floor_under_the_tum_camera_is_a_plausible_height(sensors):
    [frame] = list(open_source(sensors / "tum"))
    # the grey floor fills the bottom rows; a hand-held or tripod Kinect stands 1.0-2.0 m above it
    # (read at 1000 units per metre instead of 5000 it would be 5x higher)
    normal, height, share = fit_plane(camera_points(frame, slice(400, None)), tolerance=0.02)
    assert share > 0.5 and normal[1] < -0.7  # a floor: it faces up, i.e. against the camera's y (down)
    assert 1.0 < height < 2.0, height


def _sequence(folder, sensors, with_truth=True):
    """A TUM sequence folder of two frames made from the sample pair (copied, never edited)."""
    (folder / "rgb").mkdir(parents=True)
    (folder / "depth").mkdir()
    for stamp in ("100.000000", "100.033000"):
        shutil.copy(sensors / "tum" / "TUM_color.png", folder / "rgb" / f"{stamp}.png")
    for stamp in ("100.004000", "100.030000", "105.000000"):  # the last has no colour within 20 ms
        shutil.copy(sensors / "tum" / "TUM_depth.png", folder / "depth" / f"{stamp}.png")
    (folder / "rgb.txt").write_text("# color images\n100.000000 rgb/100.000000.png\n100.033000 rgb/100.033000.png\n")
    (folder / "depth.txt").write_text("# depth\n100.004000 depth/100.004000.png\n100.030000 depth/100.030000.png\n"
                                      "105.000000 depth/105.000000.png\n")
    if with_truth:
        (folder / "groundtruth.txt").write_text("# timestamp tx ty tz qx qy qz qw\n"
                                                "100.0040 1.0 2.0 1.5 0 0 0.7071068 0.7071068\n")


def test_a_tum_sequence_pairs_colour_and_depth_by_stamp_and_takes_ground_truth_as_a_prior(tmp_path, sensors):
    _sequence(tmp_path / "seq", sensors)
    frames = list(open_source(tmp_path / "seq"))
    assert [f.time for f in frames] == [pytest.approx(100.004), pytest.approx(100.030)]
    first, second = frames
    assert first.pose_is_prior and np.allclose(first.T_world_camera[:3, 3], (1.0, 2.0, 1.5))
    assert np.allclose(first.T_world_camera[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-6)  # 90 deg yaw
    assert second.T_world_camera is None  # no ground truth within 20 ms
    assert first.source == "depth/100.004000.png"


def test_a_tum_sequence_depth_scale_can_be_overridden_and_is_checked(tmp_path, sensors):
    _sequence(tmp_path / "seq", sensors, with_truth=False)
    [frame, _] = list(open_source(tmp_path / "seq"))
    [halved, _] = list(open_source(tmp_path / "seq", depth_scale=10000))
    assert np.allclose(halved.depth, frame.depth / 2)
    with pytest.raises(SourceError, match="looks like millimetres; give depth_scale"):
        list(open_source(tmp_path / "seq", depth_scale=100))


def test_a_pair_folder_of_unknown_origin_needs_its_scale_and_intrinsics(tmp_path, sensors):
    folder = tmp_path / "pair"
    folder.mkdir()
    shutil.copy(sensors / "tum" / "TUM_color.png", folder / "shot_color.png")
    shutil.copy(sensors / "tum" / "TUM_depth.png", folder / "shot_depth.png")
    with pytest.raises(SourceError, match="the depth PNGs' units are unknown: give depth_scale"):
        open_source(folder)
    with pytest.raises(SourceError, match=r"shot_depth.png: no camera intrinsics in the recording; give them"):
        list(open_source(folder, depth_scale=5000))
    (folder / "intrinsics.json").write_text('{"fx": 520.9, "fy": 521.0, "cx": 325.1, "cy": 249.7, '
                                            '"depth_scale": 5000}')
    [frame] = list(open_source(folder))
    assert frame.intrinsics.fx == 520.9 and np.nanmedian(frame.depth[frame.valid_depth]) == pytest.approx(2.4, 0.1)


def test_bad_pairs_are_one_line_errors(tmp_path, sensors):
    folder = tmp_path / "bad"
    folder.mkdir()
    colour = cv2.imread(str(sensors / "tum" / "TUM_color.png"))
    cv2.imwrite(str(folder / "a_color.png"), colour[:240, :320])
    shutil.copy(sensors / "tum" / "TUM_depth.png", folder / "a_depth.png")
    with pytest.raises(SourceError, match=r"a_depth.png: depth is 640x480 but its colour image a_color.png is "
                                          r"320x240"):
        list(open_source(folder, depth_scale=5000, intrinsics=dict(fx=525, fy=525, cx=319.5, cy=239.5)))
    cv2.imwrite(str(folder / "a_color.png"), colour)
    cv2.imwrite(str(folder / "a_depth.png"), colour)  # a colour image where depth should be
    with pytest.raises(SourceError, match=r"a_depth.png: depth must be one channel"):
        list(open_source(folder, depth_scale=5000, intrinsics=dict(fx=525, fy=525, cx=319.5, cy=239.5)))
    cv2.imwrite(str(folder / "a_depth.png"), np.zeros((480, 640), np.uint16))
    with pytest.raises(SourceError, match=r"a_depth.png: the depth image has no valid pixel"):
        list(open_source(folder, depth_scale=5000, intrinsics=dict(fx=525, fy=525, cx=319.5, cy=239.5)))
