"""``bim2rdt demo --record run.mcap``: the simulated robot's run as a ROS 2 bag, as a RealSense D435i on a legged
robot would have recorded it (REP 105 frames, RealSense ROS 2 wrapper topic names).

- ``/camera/camera/color/image_raw`` (rgb8), ``/camera/camera/aligned_depth_to_color/image_raw`` (16UC1 mm),
  ``/camera/camera/color/camera_info`` (plumb_bob, no distortion), frame ``camera_color_optical_frame``;
- ``/camera/camera/imu`` (``camera_imu_optical_frame``): the specific force at rest, g along the true up;
- ``/tf``: ``map -> odom`` (identity: the robot leaves a surveyed dock and its odometry starts there),
  ``odom -> base_link`` (the robot's odometry, drifting as the demo's does), ``base_link -> camera_link`` (the
  camera's height and tilt head); ``/tf_static``: ``camera_link -> camera_color_optical_frame`` and
  ``camera_link -> camera_imu_optical_frame`` (the optical rotation).

The robot's clock: each leg takes its metres at ``SPEED`` and its turn at ``TURN_RATE``; a capture takes
``CAPTURE_S``. Nothing here is read back by the library: the bag holds what the robot measured, the IMU aside
(a simulated sensor reads the true gravity).
"""

from __future__ import annotations

import numpy as np

from bim2rdt.frames import UP
from bim2rdt.localization import Turned
from bim2rdt.localization.planar import compose, from_planar, to_planar
from bim2rdt.sources.bag_writer import COLOUR, DEPTH, IMU, IMU_FRAME, INFO, OPTICAL, BagWriter

SPEED, TURN_RATE, CAPTURE_S = 0.5, 0.8, 0.2
R_LINK_OPTICAL = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
"""camera_link (x forward, z up) <- optical frame (x right, y down, z forward)."""


def _rigid(R: np.ndarray, t=(0.0, 0.0, 0.0)) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    return T


class RecordingRobot:
    """A :class:`~bim2rdt.mission.robot.Robot` that passes every command to ``robot`` (a simulated robot) and
    writes what it measured into ``bag``: its odometry as TF, and every captured frame. Without a bag it only
    keeps ``captures``: each capture's (time, T_odom_camera) on the robot's clock, as the bag would hold them
    (what ``demo --publish`` corrects into ``map -> odom``)."""

    def __init__(self, robot, bag: BagWriter | None, dock: np.ndarray, start_time: float) -> None:
        self.robot, self.bag, self.time = robot, bag, start_time
        self.state, self.tilt = to_planar(dock)
        self.frames = 0
        self.captures: list[tuple[float, np.ndarray]] = []
        T_link_optical = _rigid(R_LINK_OPTICAL)
        if bag is not None:
            bag.write_tf([("camera_link", OPTICAL, T_link_optical), ("camera_link", IMU_FRAME, T_link_optical)],
                         start_time, static=True)
        self._write_tf()

    def drive(self, increment: np.ndarray, R_level_camera: np.ndarray):
        reading = self.robot.drive(increment, R_level_camera)
        self._moved(reading.increment, reading.distance, reading.turned)
        self.tilt = R_level_camera
        self._write_tf()
        return reading

    def capture(self):
        frame = self.robot.capture()
        self._record(frame)
        return frame

    def turn(self, angle: float) -> Turned:
        turned = self.robot.turn(angle)
        self._moved(turned.increment, turned.distance, turned.turned)
        self._record(turned.frame)
        return turned

    def _moved(self, increment, distance: float, turned: float) -> None:
        self.state = compose(self.state, np.asarray(increment, float))
        self.time += distance / SPEED + turned / TURN_RATE

    def _write_tf(self) -> None:
        if self.bag is None:
            return
        T_odom_optical = from_planar(self.state, self.tilt)
        x, y, _, yaw = self.state
        c, s = np.cos(yaw), np.sin(yaw)
        T_odom_base = _rigid(np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]), (x, y, 0.0))
        T_base_link = np.linalg.inv(T_odom_base) @ T_odom_optical @ np.linalg.inv(_rigid(R_LINK_OPTICAL))
        self.bag.write_tf([("map", "odom", np.eye(4)), ("odom", "base_link", T_odom_base),
                           ("base_link", "camera_link", T_base_link)], self.time)

    def _record(self, frame) -> None:
        self.time += CAPTURE_S
        self._write_tf()
        t = self.time
        self.captures.append((t, from_planar(self.state, self.tilt)))
        self.frames += 1
        if self.bag is None:
            return
        self.bag.write_camera_info(INFO, OPTICAL, t, frame.intrinsics)
        self.bag.write_colour(COLOUR, OPTICAL, t, frame.rgb)
        self.bag.write_depth(DEPTH, OPTICAL, t, frame.depth)
        R_world_camera = self.robot.T_world_camera[:3, :3]
        self.bag.write_imu(IMU, IMU_FRAME, t, R_world_camera.T @ UP)
