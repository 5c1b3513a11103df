"""ROS bags through open_source: frames as written (colour, REP 118 depth, CameraInfo), TF priors interpolated
at the image stamps, colour/depth synced within the tolerance with dropped frames counted by reason,
subsampling, IMU up, and bad bags in one line."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from bim2rdt.sources import SourceError, open_source
from bim2rdt.sources.bag_writer import BagWriter, bag_folder, storage_file
from tests.sources.bags import CAMERA, DEPTH, IMU, INFO, SMALL, small_frame, write_bag


def test_a_written_bag_reads_back_as_its_frames_from_the_folder_and_from_its_mcap(tmp_path):
    rgb, depth = write_bag(tmp_path / "run.mcap", [1.0, 2.0])
    assert (bag_folder(tmp_path / "run.mcap") / "metadata.yaml").is_file()
    for path in (tmp_path / "run", storage_file(tmp_path / "run.mcap")):
        frames = list(open_source(path))
        assert len(frames) == 2
        assert np.array_equal(frames[0].rgb, rgb)
        assert np.allclose(frames[0].depth, depth, atol=5.1e-4)  # 16UC1: millimetres
        assert frames[0].intrinsics == SMALL and frames[0].pose_is_prior
        assert frames[1].time == pytest.approx(2.005)


def test_the_camera_prior_is_interpolated_in_tf_at_the_depth_stamp(tmp_path):
    write_bag(tmp_path / "run.mcap", [1.0, 1.5], odom_times=[0.9, 1.1, 1.4, 1.6])
    frames = list(open_source(tmp_path / "run"))
    assert [f.T_world_camera[0, 3] for f in frames] == pytest.approx([1.005, 1.505])  # odom x = t, between samples


def test_frames_without_a_depth_partner_or_tf_within_the_tolerance_are_dropped_with_their_reason(tmp_path):
    write_bag(tmp_path / "late.mcap", [1.0, 2.0], depth_offset=0.03)
    late = open_source(tmp_path / "late")
    assert list(late) == [] and late.drop_counts == {"no depth image within 20 ms": 2}
    assert len(list(open_source(tmp_path / "late", sync_tolerance=0.05))) == 2
    write_bag(tmp_path / "notf.mcap", [1.0, 2.0, 3.0], odom_times=[0.9, 1.0, 1.1])
    source = open_source(tmp_path / "notf")
    assert len(list(source)) == 1 and source.drop_counts == {"no TF within tolerance": 2}
    assert "odom -> base_link" in source.dropped[0]["reason"]


def test_every_and_max_frames_subsample(tmp_path):
    write_bag(tmp_path / "run.mcap", [1.0, 2.0, 3.0, 4.0, 5.0])
    assert [f.time for f in open_source(tmp_path / "run", every=2)] == pytest.approx([1.005, 3.005, 5.005])
    assert len(list(open_source(tmp_path / "run", every=2, max_frames=2))) == 2


def test_the_imu_up_is_rotated_into_the_camera_frame(tmp_path):
    rgb, depth = small_frame()
    R = np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]])  # camera optical frame in base_link: y down = -z_base
    T_base_camera = np.eye(4)
    T_base_camera[:3, :3] = R
    with BagWriter(tmp_path / "imu.mcap") as bag:
        bag.write_tf([("map", "base_link", np.eye(4)), ("base_link", CAMERA, T_base_camera),
                      ("base_link", "imu_link", np.eye(4))], 0.0, static=True)
        bag.write_imu(IMU, "imu_link", 1.0, (0, 0, 1))
        bag.write_camera_info("/camera/camera/color/camera_info", CAMERA, 1.0, SMALL)
        bag.write_depth(DEPTH, CAMERA, 1.0, depth)
    frame = next(iter(open_source(tmp_path / "imu")))
    assert frame.up == pytest.approx([0.0, -1.0, 0.0])  # up is -y in an optical frame of a level camera


@pytest.mark.parametrize("damage, message", [
    ("no_images", "no image topics"),
    ("no_info", "has no sensor_msgs/CameraInfo"),
    ("encoding", "unknown colour encoding 'yuv422'"),
    ("no_tf_path", "no path to the camera frame"),
    ("truncated", "not a readable bag"),
    ("no_metadata", "without metadata.yaml"),
    ("fisheye", "distortion model 'equidistant' is not supported"),
])
def test_a_damaged_bag_is_refused_in_one_line(tmp_path, damage, message):
    path = tmp_path / "bad.mcap"
    if damage == "no_images":
        with BagWriter(path) as bag:
            bag.write_tf([("map", "base_link", np.eye(4))], 0.0, static=True)
    elif damage == "no_info":
        write_bag(path, [1.0], info=False)
    elif damage == "encoding":
        write_bag(path, [1.0], encoding="yuv422")
    elif damage == "no_tf_path":
        with BagWriter(path) as bag:
            bag.write_tf([("map", "odom", np.eye(4))], 0.0, static=True)
            bag.write_camera_info("/camera/camera/color/camera_info", CAMERA, 1.0, SMALL)
            bag.write_depth(DEPTH, CAMERA, 1.0, small_frame()[1])
    elif damage == "fisheye":
        with BagWriter(path) as bag:
            T = bag.types
            bag.write("/camera/camera/color/camera_info", T["sensor_msgs/msg/CameraInfo"](
                header=bag.header(CAMERA, 1.0), height=SMALL.height, width=SMALL.width,
                distortion_model="equidistant", d=np.array([0.1, 0.0, 0.0, 0.0]),
                k=np.array([SMALL.fx, 0, SMALL.cx, 0, SMALL.fy, SMALL.cy, 0, 0, 1.0]), r=np.eye(3).reshape(-1),
                p=np.zeros(12), binning_x=0, binning_y=0, roi=T["sensor_msgs/msg/RegionOfInterest"](
                    x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)), 1.0)
            bag.write_depth(DEPTH, CAMERA, 1.0, small_frame()[1])
    elif damage == "truncated":
        write_bag(path, [1.0, 2.0])
        data = storage_file(path).read_bytes()
        storage_file(path).write_bytes(data[: len(data) // 2])
    with pytest.raises(SourceError) as error:
        if damage == "truncated":
            list(open_source(storage_file(path)))
        elif damage == "no_metadata":
            write_bag(path, [1.0])
            (bag_folder(path) / "metadata.yaml").unlink()
            open_source(bag_folder(path))
        else:
            list(open_source(bag_folder(path)))
    assert message in str(error.value) and "\n" not in str(error.value)


def test_a_db3_bag_reads_too(tmp_path):
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    write_bag(tmp_path / "run.mcap", [1.0, 2.0])
    store = get_typestore(Stores.ROS2_HUMBLE)
    from rosbags.highlevel import AnyReader

    with AnyReader([tmp_path / "run"], default_typestore=store) as reader, \
            Writer(tmp_path / "db", version=8, storage_plugin=StoragePlugin.SQLITE3) as writer:
        connections = {c.id: writer.add_connection(c.topic, c.msgtype, typestore=store) for c in reader.connections}
        for connection, time, raw in reader.messages():
            writer.write(connections[connection.id], time, raw)
    assert [f.time for f in open_source(tmp_path / "db")] == pytest.approx([1.005, 2.005])
    shutil.rmtree(tmp_path / "run")


def test_a_bag_whose_header_stamps_and_receive_times_disagree_is_reported_not_re_timed(tmp_path):
    from tests.sources.bags import COLOUR, INFO

    rgb, depth = small_frame()
    with BagWriter(tmp_path / "skew.mcap") as bag:
        bag.write_camera_info(INFO, CAMERA, 1.0, SMALL)
        for t in (1.0, 2.0):
            header_time = t
            bag.write_colour(COLOUR, CAMERA, header_time, rgb)
            message = bag.types["sensor_msgs/msg/Image"](
                header=bag.header(CAMERA, header_time), height=SMALL.height, width=SMALL.width, encoding="32FC1",
                is_bigendian=0, step=SMALL.width * 4, data=depth.astype("<f4").reshape(-1).view(np.uint8))
            bag.write(DEPTH, message, header_time + 5.0)  # received 5 s after its stamp: another clock
    source = open_source(tmp_path / "skew")
    frames = list(source)
    assert [f.time for f in frames] == pytest.approx([1.0, 2.0])  # synced on the stamps as recorded
    assert np.allclose(frames[0].depth, depth)  # 32FC1: metres as they are
    assert any("clocks disagree" in w and "+5.0 s" not in w and "-5.0 s" in w for w in source.warnings)


def test_a_ros1_bag_reads_too(tmp_path):
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    T = store.types
    rgb, depth = small_frame()

    def header(t):
        return T["std_msgs/msg/Header"](seq=0, stamp=T["builtin_interfaces/msg/Time"](sec=t, nanosec=0),
                                        frame_id=CAMERA)

    with Writer(tmp_path / "run.bag") as writer:
        info = writer.add_connection("/camera/color/camera_info", "sensor_msgs/msg/CameraInfo", typestore=store)
        image = writer.add_connection("/camera/depth/image_rect_raw", "sensor_msgs/msg/Image", typestore=store)
        millimetres = np.round(depth * 1000).astype("<u2")
        for t in (1, 2):
            K = np.array([SMALL.fx, 0, SMALL.cx, 0, SMALL.fy, SMALL.cy, 0, 0, 1.0])
            message = T["sensor_msgs/msg/CameraInfo"](
                header=header(t), height=SMALL.height, width=SMALL.width, distortion_model="plumb_bob",
                D=np.zeros(5), K=K, R=np.eye(3).reshape(-1), P=np.zeros(12), binning_x=0, binning_y=0,
                roi=T["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False))
            writer.write(info, t * 10**9, store.serialize_ros1(message, "sensor_msgs/msg/CameraInfo"))
            message = T["sensor_msgs/msg/Image"](header=header(t), height=SMALL.height, width=SMALL.width,
                                                 encoding="16UC1", is_bigendian=0, step=SMALL.width * 2,
                                                 data=millimetres.reshape(-1).view(np.uint8))
            writer.write(image, t * 10**9, store.serialize_ros1(message, "sensor_msgs/msg/Image"))
    frames = list(open_source(tmp_path / "run.bag"))
    assert [f.time for f in frames] == [1.0, 2.0] and frames[0].intrinsics == SMALL
    assert frames[0].T_world_camera is None  # no TF: no prior
    assert np.allclose(frames[0].depth, depth, atol=5.1e-4)


def test_plumb_bob_distortion_is_removed_from_depth_by_nearest_neighbour(tmp_path):
    import cv2

    rgb, depth = small_frame()
    d = np.array([0.2, -0.1, 0.0, 0.0, 0.0])
    with BagWriter(tmp_path / "distorted.mcap") as bag:
        T = bag.types
        K = np.array([SMALL.fx, 0, SMALL.cx, 0, SMALL.fy, SMALL.cy, 0, 0, 1.0])
        bag.write("/camera/camera/color/camera_info", T["sensor_msgs/msg/CameraInfo"](
            header=bag.header(CAMERA, 1.0), height=SMALL.height, width=SMALL.width, distortion_model="plumb_bob",
            d=d, k=K, r=np.eye(3).reshape(-1), p=np.zeros(12), binning_x=0, binning_y=0,
            roi=T["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)),
            1.0)
        bag.write_depth(DEPTH, CAMERA, 1.0, depth)
    frame = next(iter(open_source(tmp_path / "distorted")))
    raw = np.round(depth.astype(np.float64) * 1000).astype(np.uint16)  # as the writer rounds
    maps = cv2.initUndistortRectifyMap(K.reshape(3, 3), d, None, K.reshape(3, 3), (SMALL.width, SMALL.height),
                                       cv2.CV_32FC1)
    expected = cv2.remap(raw, *maps, cv2.INTER_NEAREST).astype(np.float32) / 1000
    assert not np.allclose(expected, raw / 1000)  # the distortion moves pixels
    assert np.allclose(frame.depth, expected, atol=1e-6)


@pytest.mark.parametrize("width, height, message", [
    (SMALL.width * 2, SMALL.height * 2, "CameraInfo is for 128x96 images but the image is 64x48"),
    (20000, 20000, "CameraInfo is for 20000x20000 images but the image is 64x48"),
    (60000, 60000, "declares a 60000x60000 image"),
])
def test_a_camera_info_whose_size_is_not_the_images_is_refused_before_any_map_is_built(tmp_path, width, height,
                                                                                       message):
    """A small bag whose CameraInfo declares a huge distorted image: refused in one line, without building the
    undistortion maps at CameraInfo's size (20000 x 20000 took 6.9 GB before it ended in cv2.error)."""
    import tracemalloc

    from bim2rdt.sources import ros_images

    rgb, depth = small_frame()
    with BagWriter(tmp_path / "liar.mcap") as bag:
        T = bag.types
        K = np.array([SMALL.fx, 0, SMALL.cx, 0, SMALL.fy, SMALL.cy, 0, 0, 1.0])
        bag.write("/camera/camera/color/camera_info", T["sensor_msgs/msg/CameraInfo"](
            header=bag.header(CAMERA, 1.0), height=height, width=width, distortion_model="plumb_bob",
            d=np.array([0.2, -0.1, 0.0, 0.0, 0.0]), k=K, r=np.eye(3).reshape(-1), p=np.zeros(12), binning_x=0,
            binning_y=0, roi=T["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0,
                                                                     do_rectify=False)), 1.0)
        bag.write_depth(DEPTH, CAMERA, 1.0, depth)
    built = []
    real = ros_images.cv2.initUndistortRectifyMap

    def build(*args):  # records the size asked for; never allocates a huge one (main asked for 20000 x 20000)
        built.append(args[4])
        assert args[4][0] * args[4][1] <= SMALL.width * SMALL.height, f"maps built at {args[4]}"
        return real(*args)

    tracemalloc.start()
    try:
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(ros_images.cv2, "initUndistortRectifyMap", build)
            with pytest.raises(SourceError) as error:
                list(open_source(tmp_path / "liar"))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert message in str(error.value) and "\n" not in str(error.value)
    assert built == [] and peak < 200e6


def test_negative_header_stamps_are_refused_in_one_line(tmp_path):
    """A sensor whose clock was never set: stamps before 1970 would date the twin's events in 1913 (decision
    0036: refused, not replaced by receive times)."""
    with BagWriter(tmp_path / "unset.mcap") as bag:
        honest = bag.header
        bag.header = lambda frame_id, time: honest(frame_id, time - 1.8e9)  # receive times stay positive
        bag.write_tf([("map", CAMERA, np.eye(4))], 0.0, static=True)
        bag.write_camera_info(INFO, CAMERA, 1.0, SMALL)
        bag.write_depth(DEPTH, CAMERA, 1.0, small_frame()[1])
    with pytest.raises(SourceError) as error:
        list(open_source(tmp_path / "unset"))
    assert "before 1970" in str(error.value) and "\n" not in str(error.value)


def test_a_tf_cycle_above_the_camera_is_refused_in_one_line(tmp_path):
    with BagWriter(tmp_path / "cycle.mcap") as bag:
        bag.write_tf([("base_link", CAMERA, np.eye(4)), ("odom", "base_link", np.eye(4)),
                      ("base_link", "odom", np.eye(4))], 0.0, static=True)
        bag.write_camera_info(INFO, CAMERA, 1.0, SMALL)
        bag.write_depth(DEPTH, CAMERA, 1.0, small_frame()[1])
    with pytest.raises(SourceError) as error:
        list(open_source(tmp_path / "cycle"))
    assert "cycle (base_link -> odom -> base_link)" in str(error.value) and "\n" not in str(error.value)


def test_the_tf_error_line_lists_a_bounded_number_of_frames(tmp_path):
    with BagWriter(tmp_path / "many.mcap") as bag:
        bag.write_tf([("map", f"frame_{i:05d}", np.eye(4)) for i in range(5000)], 0.0, static=True)
        bag.write_camera_info(INFO, CAMERA, 1.0, SMALL)
        bag.write_depth(DEPTH, CAMERA, 1.0, small_frame()[1])
    with pytest.raises(SourceError) as error:
        list(open_source(tmp_path / "many"))
    assert "no path to the camera frame" in str(error.value) and "and 4981 more" in str(error.value)
    assert len(str(error.value)) < 1000
