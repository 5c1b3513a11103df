"""ROS 2 bags out (``rosbags``' writer, no ROS install): a rosbag2 folder (metadata.yaml + one ``.mcap``) with
the messages bim2rdt writes: RGB-D frames as a RealSense driver publishes them, TF, IMU, and the twin's results.

The bag is written into a temporary folder beside the target and renamed when closed, so a failed run leaves no
half bag. ``bag_folder("run.mcap")`` is the folder ``run/`` whose storage file is ``run/run.mcap``: what
``ros2 bag record -s mcap -o run`` makes; ``open_source`` reads either.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np

from bim2rdt.perception import Intrinsics
from bim2rdt.sources.optional import require
from bim2rdt.sources.tf import translation_quaternion

GRAVITY = 9.80665
COLOUR, DEPTH = "/camera/camera/color/image_raw", "/camera/camera/aligned_depth_to_color/image_raw"
INFO, IMU = "/camera/camera/color/camera_info", "/camera/camera/imu"
OPTICAL, IMU_FRAME = "camera_color_optical_frame", "camera_imu_optical_frame"
"""A RealSense's topics and frames (the ROS 2 wrapper's defaults, namespace /camera/camera)."""


def bag_folder(path) -> Path:
    """The rosbag2 folder for ``path`` (a folder, or ``name.mcap``: its folder ``name/``)."""
    path = Path(path)
    return path.with_suffix("") if path.suffix.lower() == ".mcap" else path


def storage_file(path) -> Path:
    """The ``.mcap`` inside the bag folder of ``path``."""
    folder = bag_folder(path)
    return folder / f"{folder.name}.mcap"


class BagWriter:
    """Open with ``with BagWriter(path) as bag:``; each ``write_*`` takes a time in seconds (header stamp and
    receive time). Topics are created on first use. The bag is written to a hidden temporary folder beside its
    own and takes its place when the ``with`` block ends without an error; an error removes it.

    Args:
        path: The bag's folder, or ``name.mcap`` for the folder ``name/`` (:func:`bag_folder`).

    Raises:
        SourceError: The ``rosbags`` package is not installed.
    """

    def __init__(self, path: str | Path) -> None:
        require("rosbags.rosbag2", path, "ROS bags", "ros")
        from rosbags.rosbag2 import StoragePlugin, Writer
        from rosbags.typesys import Stores, get_typestore

        self.folder = bag_folder(path)
        self._temporary = self.folder.with_name(f".{self.folder.name}.writing")
        shutil.rmtree(self._temporary, ignore_errors=True)
        self.store = get_typestore(Stores.ROS2_HUMBLE)
        self.types = self.store.types
        self._writer = Writer(self._temporary, version=8, storage_plugin=StoragePlugin.MCAP)
        self._connections: dict[str, object] = {}

    def __enter__(self) -> BagWriter:
        self._writer.open()
        return self

    def __exit__(self, kind, error, trace) -> None:
        self._writer.close()
        if error is not None:
            shutil.rmtree(self._temporary, ignore_errors=True)
            return
        (self._temporary / f"{self._temporary.name}.mcap").rename(self._temporary / f"{self.folder.name}.mcap")
        metadata = self._temporary / "metadata.yaml"
        metadata.write_text(metadata.read_text().replace(f"{self._temporary.name}.mcap", f"{self.folder.name}.mcap"))
        shutil.rmtree(self.folder, ignore_errors=True)
        self._temporary.rename(self.folder)

    # -- messages --------------------------------------------------------------------------------------------

    def write(self, topic: str, message: object, time: float) -> None:
        """Write any message of the ROS 2 Humble typestore (``self.types``).

        Args:
            topic: The topic; its connection is made on first use.
            message: A message built from ``self.types``.
            time: The receive time, seconds.
        """
        connection = self._connections.get(topic)
        if connection is None:
            connection = self._connections[topic] = self._writer.add_connection(
                topic, message.__msgtype__, typestore=self.store)
        self._writer.write(connection, int(round(time * 1e9)), self.store.serialize_cdr(message, message.__msgtype__))

    def header(self, frame_id: str, time: float) -> object:
        """A ``std_msgs/Header`` for messages built from ``self.types``.

        Args:
            frame_id: The frame the message's data is in.
            time: The stamp, seconds.

        Returns:
            The header: ``time`` split into whole seconds and nanoseconds, and ``frame_id``.
        """
        T = self.types
        sec = int(np.floor(time))
        return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](
            sec=sec, nanosec=int(round((time - sec) * 1e9)) % 1_000_000_000), frame_id=frame_id)

    def write_colour(self, topic: str, frame_id: str, time: float, rgb: np.ndarray) -> None:
        """Write a colour image as a RealSense sends it: ``rgb8``.

        Args:
            topic: The image topic.
            frame_id: The camera's optical frame.
            time: The stamp and receive time, seconds.
            rgb: (H, W, 3) the image, 8 bits per channel.
        """
        height, width = rgb.shape[:2]
        self.write(topic, self.types["sensor_msgs/msg/Image"](
            header=self.header(frame_id, time), height=height, width=width, encoding="rgb8", is_bigendian=0,
            step=width * 3, data=np.ascontiguousarray(rgb, np.uint8).reshape(-1)), time)

    def write_depth(self, topic: str, frame_id: str, time: float, depth_m: np.ndarray) -> None:
        """Write depth as a RealSense sends it: 16UC1 millimetres (REP 118), 0 = no return.

        Args:
            topic: The depth image topic.
            frame_id: The camera's optical frame.
            time: The stamp and receive time, seconds.
            depth_m: (H, W) depth in metres; NaN or inf = no return (written as 0), clipped to 0-65.535 m.
        """
        depth = np.nan_to_num(np.asarray(depth_m, np.float64), nan=0.0, posinf=0.0)
        millimetres = np.clip(np.round(depth * 1000.0), 0, 65535).astype("<u2")
        height, width = millimetres.shape
        self.write(topic, self.types["sensor_msgs/msg/Image"](
            header=self.header(frame_id, time), height=height, width=width, encoding="16UC1", is_bigendian=0,
            step=width * 2, data=millimetres.reshape(-1).view(np.uint8)), time)

    def write_camera_info(self, topic: str, frame_id: str, time: float, intrinsics: Intrinsics) -> None:
        """Write a ``sensor_msgs/CameraInfo``: pinhole K and P from ``intrinsics``, no distortion (plumb_bob, zeros).

        Args:
            topic: The camera_info topic.
            frame_id: The camera's optical frame.
            time: The stamp and receive time, seconds.
            intrinsics: The camera's image size and pinhole parameters, pixels.
        """
        K = [intrinsics.fx, 0.0, intrinsics.cx, 0.0, intrinsics.fy, intrinsics.cy, 0.0, 0.0, 1.0]
        P = [intrinsics.fx, 0.0, intrinsics.cx, 0.0, 0.0, intrinsics.fy, intrinsics.cy, 0.0, 0.0, 0.0, 1.0, 0.0]
        T = self.types
        self.write(topic, T["sensor_msgs/msg/CameraInfo"](
            header=self.header(frame_id, time), height=intrinsics.height, width=intrinsics.width,
            distortion_model="plumb_bob", d=np.zeros(5), k=np.array(K), r=np.eye(3).reshape(-1), p=np.array(P),
            binning_x=0, binning_y=0, roi=T["sensor_msgs/msg/RegionOfInterest"](
                x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)), time)

    def _transform(self, parent: str, child: str, T_parent_child: np.ndarray, time: float):
        T = self.types
        translation, q = translation_quaternion(T_parent_child)
        return T["geometry_msgs/msg/TransformStamped"](
            header=self.header(parent, time), child_frame_id=child, transform=T["geometry_msgs/msg/Transform"](
                translation=T["geometry_msgs/msg/Vector3"](x=translation[0], y=translation[1], z=translation[2]),
                rotation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3])))

    def write_tf(self, transforms: list[tuple[str, str, np.ndarray]], time: float, static: bool = False) -> None:
        """Write transforms on /tf, or /tf_static.

        Args:
            transforms: (parent frame, child frame, T_parent_child (4, 4) metres) each.
            time: Their stamp and the receive time, seconds.
            static: Write on /tf_static (valid at every time) instead of /tf.
        """
        self.write("/tf_static" if static else "/tf", self.types["tf2_msgs/msg/TFMessage"](
            transforms=[self._transform(p, c, T, time) for p, c, T in transforms]), time)

    def write_imu(self, topic: str, frame_id: str, time: float, up: np.ndarray) -> None:
        """Write an IMU at rest: its specific force is g (9.80665 m/s^2) along ``up``; orientation unknown (REP 145).

        Args:
            topic: The IMU topic.
            frame_id: The IMU's frame.
            time: The stamp and receive time, seconds.
            up: (3,) the world's up direction in ``frame_id`` (normalised here).
        """
        T = self.types
        a = np.asarray(up, float) / np.linalg.norm(up) * GRAVITY
        unknown = np.zeros(9)
        unknown[0] = -1.0  # REP 145: orientation not provided
        self.write(topic, T["sensor_msgs/msg/Imu"](
            header=self.header(frame_id, time), orientation=T["geometry_msgs/msg/Quaternion"](x=0, y=0, z=0, w=1),
            orientation_covariance=unknown,
            angular_velocity=T["geometry_msgs/msg/Vector3"](x=0, y=0, z=0), angular_velocity_covariance=np.zeros(9),
            linear_acceleration=T["geometry_msgs/msg/Vector3"](x=a[0], y=a[1], z=a[2]),
            linear_acceleration_covariance=np.diag([1e-4] * 3).reshape(-1)), time)
