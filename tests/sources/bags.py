"""Small bags written by the tests (RealSense topic names and frames)."""

from __future__ import annotations

import numpy as np

from bim2rdt.perception.camera import Intrinsics
from bim2rdt.sources.bag_writer import BagWriter

COLOUR, DEPTH = "/camera/camera/color/image_raw", "/camera/camera/aligned_depth_to_color/image_raw"
INFO, IMU, CAMERA = "/camera/camera/color/camera_info", "/camera/camera/imu", "camera_color_optical_frame"
SMALL = Intrinsics(64, 48, 50.0, 50.0, 32.0, 24.0)


def small_frame(seed: int = 0):
    rng = np.random.default_rng(seed)
    rgb = rng.integers(0, 255, (SMALL.height, SMALL.width, 3), dtype=np.uint8)
    depth = (1.0 + rng.random((SMALL.height, SMALL.width))).astype(np.float32)
    return rgb, depth


def write_bag(path, times, *, depth_offset=0.005, tf=True, info=True, odom_times=None, colour=True,
              encoding=None, static_only=False):
    """Frames at ``times`` (colour at t, depth at t + depth_offset), odom -> base_link on /tf at
    ``odom_times`` (x = t metres), base_link -> camera on /tf_static."""
    rgb, depth = small_frame()
    with BagWriter(path) as bag:
        if tf:
            bag.write_tf([("base_link", CAMERA, np.eye(4))] + ([("map", "base_link", np.eye(4))] if static_only
                                                                 else []), 0.0, static=True)
            for t in ([] if static_only else (odom_times if odom_times is not None else times)):
                T = np.eye(4)
                T[0, 3] = t
                bag.write_tf([("odom", "base_link", T)], t)
        for t in times:
            if info:
                bag.write_camera_info(INFO, CAMERA, t, SMALL)
            if colour:
                bag.write_colour(COLOUR, CAMERA, t, rgb)
            bag.write_depth(DEPTH, CAMERA, t + depth_offset, depth)
        if encoding is not None:  # one colour image in an encoding the reader does not know
            message = bag.types["sensor_msgs/msg/Image"](
                header=bag.header(CAMERA, 99.0), height=SMALL.height, width=SMALL.width, encoding=encoding,
                is_bigendian=0, step=SMALL.width * 3, data=rgb.reshape(-1))
            bag.write(COLOUR, message, 99.0)
            bag.write_depth(DEPTH, CAMERA, 99.0, depth)
    return rgb, depth
