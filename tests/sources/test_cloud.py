"""read_cloud: each scan format written here with known points and read back exactly; office1 as a real cloud;
the NaN and millimetre rules."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.sources import SourceError, read_cloud

# Points on a 1 mm grid (exact in LAS at scale 0.001) and in float32 (multiples of 1/1024)
POINTS = np.array([[0.0, 0.0, 0.0], [1.25, -2.5, 0.75], [3.0, 4.5, 2.125], [-1.0, 0.5, 9.875]])
COLOURS = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255], [12, 34, 56]], dtype=np.uint8)
INTENSITY = np.array([10.0, 200.0, 3000.0, 40000.0])


def _las(path):
    import laspy

    las = laspy.create(point_format=3, file_version="1.2")
    las.header.scales = np.array([0.001, 0.001, 0.001])
    las.header.offsets = np.zeros(3)
    las.x, las.y, las.z = POINTS.T
    las.red, las.green, las.blue = (COLOURS.astype(np.uint16) * 257).T  # LAS colour is 16-bit
    las.intensity = INTENSITY.astype(np.uint16)
    las.write(path)


def _e57(path, translation=(0.0, 0.0, 0.0)):
    import pye57

    e57 = pye57.E57(str(path), mode="w")
    e57.write_scan_raw({"cartesianX": POINTS[:, 0], "cartesianY": POINTS[:, 1], "cartesianZ": POINTS[:, 2],
                        "colorRed": COLOURS[:, 0], "colorGreen": COLOURS[:, 1], "colorBlue": COLOURS[:, 2],
                        "intensity": INTENSITY}, translation=np.array(translation))
    e57.close()


def _ply(path):
    import trimesh

    trimesh.PointCloud(POINTS, colors=np.hstack([COLOURS, np.full((4, 1), 255, np.uint8)])).export(path)


def _pcd(path, points=POINTS):
    import pypcd4

    rgb = pypcd4.PointCloud.encode_rgb(COLOURS[: len(points)])
    cloud = pypcd4.PointCloud.from_xyzrgb_points(np.column_stack([points.astype(np.float32), rgb]))
    cloud.save(path)


@pytest.mark.parametrize("suffix, write, has_intensity", [(".las", _las, True), (".laz", _las, True),
                                                           (".e57", _e57, True), (".ply", _ply, False),
                                                           (".pcd", _pcd, False)])
def test_a_scan_written_with_known_points_reads_back_exactly(tmp_path, suffix, write, has_intensity):
    path = tmp_path / f"scan{suffix}"
    write(path)
    cloud = read_cloud(path)
    assert cloud.points.dtype == np.float64 and cloud.points.shape == (4, 3)
    assert np.allclose(cloud.points, POINTS, atol=1e-9)
    assert cloud.colors is not None and np.array_equal(cloud.colors, COLOURS)
    if has_intensity:
        assert np.allclose(cloud.intensity, INTENSITY)
    assert cloud.path == path and cloud.dropped == 0 and cloud.note == ""


def test_a_laz_file_is_really_compressed(tmp_path):
    _las(tmp_path / "scan.laz")
    _las(tmp_path / "scan.las")
    assert (tmp_path / "scan.laz").read_bytes() != (tmp_path / "scan.las").read_bytes()
    import laspy

    assert laspy.open(tmp_path / "scan.laz").header.are_points_compressed


def test_an_e57_scan_is_moved_by_its_pose_into_the_file_frame(tmp_path):
    _e57(tmp_path / "moved.e57", translation=(10.0, -5.0, 1.0))
    assert np.allclose(read_cloud(tmp_path / "moved.e57").points, POINTS + (10.0, -5.0, 1.0), atol=1e-9)


def test_office1_reads_as_a_cloud_of_its_valid_points(sensors):
    cloud = read_cloud(sensors / "pcl" / "office1.pcd")
    assert len(cloud) == 254_456 and cloud.dropped == 640 * 480 - 254_456  # SOURCES.md: valid points
    assert np.isfinite(cloud.points).all()
    assert 4.0 < np.median(cloud.points[:, 2]) < 5.0  # metres: the door wall about 4.7 m ahead (SOURCES.md)
    assert cloud.colors.shape == (254_456, 3) and cloud.colors.std() > 10


def test_a_scan_in_millimetres_is_refused_or_converted_when_told(tmp_path):
    import trimesh

    room = np.random.default_rng(1).uniform([0, 0, 0], [5000, 4000, 3000], (500, 3))  # a 5 m room in mm
    trimesh.PointCloud(room).export(tmp_path / "room_mm.ply")
    with pytest.raises(SourceError, match=r"room_mm.ply: the scan spans \d+ units: it looks like millimetres.*"
                                          r"scale=0.001") as error:
        read_cloud(tmp_path / "room_mm.ply")
    assert "\n" not in str(error.value)
    cloud = read_cloud(tmp_path / "room_mm.ply", scale=0.001)
    assert np.allclose(cloud.points, room * 0.001, atol=1e-6) and "0.001" in cloud.note


def test_no_return_rows_are_dropped_and_partly_nan_rows_are_refused(tmp_path):
    with_holes = POINTS.copy()
    with_holes[1] = np.nan
    _pcd(tmp_path / "holes.pcd", with_holes)
    cloud = read_cloud(tmp_path / "holes.pcd")
    assert cloud.dropped == 1 and np.allclose(cloud.points, POINTS[[0, 2, 3]])
    assert np.array_equal(cloud.colors, COLOURS[[0, 2, 3]])
    damaged = POINTS.copy()
    damaged[2, 1] = np.nan
    _pcd(tmp_path / "damaged.pcd", damaged)
    with pytest.raises(SourceError, match=r"damaged.pcd: 1 points have a NaN .* row 2"):
        read_cloud(tmp_path / "damaged.pcd")
    _pcd(tmp_path / "empty.pcd", np.full((3, 3), np.nan))
    with pytest.raises(SourceError, match=r"empty.pcd: no points \(every row is NaN\)"):
        read_cloud(tmp_path / "empty.pcd")


def test_unknown_missing_and_damaged_files_are_one_line_errors(tmp_path):
    with pytest.raises(SourceError, match=r"scan.xyz: no scan reader for '.xyz'"):
        read_cloud(tmp_path / "scan.xyz")
    with pytest.raises(SourceError, match="absent.las: no such file"):
        read_cloud(tmp_path / "absent.las")
    for suffix in (".las", ".e57", ".pcd", ".ply"):
        (tmp_path / f"junk{suffix}").write_bytes(b"this is not a scan\n" * 10)
        with pytest.raises(SourceError, match=f"junk{suffix}: ") as error:
            read_cloud(tmp_path / f"junk{suffix}")
        assert "\n" not in str(error.value)
