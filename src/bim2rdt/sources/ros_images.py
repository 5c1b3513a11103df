"""ROS image messages to arrays: ``sensor_msgs/Image`` colour and depth (REP 118), ``CompressedImage`` and
``CameraInfo``, each refusing what it cannot read in one line that names the topic."""

from __future__ import annotations

import cv2
import numpy as np

from bim2rdt.perception import Intrinsics
from bim2rdt.sources.budget import MAX_IMAGE_SIDE as MAX_SIDE

COLOUR_ENCODINGS = {"rgb8": (3, None), "bgr8": (3, cv2.COLOR_BGR2RGB), "rgba8": (4, cv2.COLOR_RGBA2RGB),
                    "bgra8": (4, cv2.COLOR_BGRA2RGB), "mono8": (1, cv2.COLOR_GRAY2RGB)}
"""Colour encoding -> (channels, OpenCV conversion to RGB)."""
DEPTH_ENCODINGS = {"16UC1": (np.uint16, 1000.0), "mono16": (np.uint16, 1000.0), "32FC1": (np.float32, 1.0)}
"""Depth encoding -> (dtype, units per metre): REP 118, 16-bit millimetres or 32-bit float metres."""


class ImageError(ValueError):
    """A message that is not a readable image (the reader names the topic)."""


def is_depth(encoding: str) -> bool:
    return encoding.upper() in {e.upper() for e in DEPTH_ENCODINGS}


def colour(message) -> np.ndarray:
    """(H, W, 3) uint8 RGB of a ``sensor_msgs/Image`` in one of :data:`COLOUR_ENCODINGS`."""
    encoding = message.encoding.lower()
    if encoding not in COLOUR_ENCODINGS:
        raise ImageError(f"unknown colour encoding '{message.encoding}' (readable: "
                         f"{', '.join(COLOUR_ENCODINGS)}, depth {', '.join(DEPTH_ENCODINGS)})")
    channels, conversion = COLOUR_ENCODINGS[encoding]
    image = _rows(message, np.uint8, channels)
    if channels == 1:
        image = image[..., 0]
    return np.ascontiguousarray(image) if conversion is None else cv2.cvtColor(image, conversion)


def depth(message) -> tuple[np.ndarray, float]:
    """(raw depth (H, W), units per metre) of a ``sensor_msgs/Image`` in one of :data:`DEPTH_ENCODINGS`."""
    key = next((e for e in DEPTH_ENCODINGS if e.upper() == message.encoding.upper()), None)
    if key is None:
        raise ImageError(f"unknown depth encoding '{message.encoding}' (readable: {', '.join(DEPTH_ENCODINGS)})")
    dtype, units = DEPTH_ENCODINGS[key]
    return _rows(message, dtype, 1)[..., 0], units


def compressed_colour(message) -> np.ndarray:
    """(H, W, 3) uint8 RGB of a jpeg/png ``sensor_msgs/CompressedImage``."""
    image = cv2.imdecode(np.frombuffer(bytes(message.data), np.uint8), cv2.IMREAD_COLOR)
    if image is None:
        raise ImageError(f"compressed image in format '{message.format}' does not decode (jpeg or png)")
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)


def _rows(message, dtype, channels: int) -> np.ndarray:
    """The message's pixels (H, W, C) honouring ``step`` (row padding) and ``is_bigendian``."""
    dtype = np.dtype(dtype).newbyteorder(">" if message.is_bigendian else "<")
    data = np.frombuffer(bytes(message.data) if not isinstance(message.data, np.ndarray) else message.data,
                         np.uint8)
    row = message.width * channels * dtype.itemsize
    if message.step < row or data.size < message.step * message.height:
        raise ImageError(f"{message.width}x{message.height} {message.encoding} image has {data.size} bytes "
                         f"(step {message.step}): truncated")
    rows = data[: message.step * message.height].reshape(message.height, message.step)[:, :row]
    return np.ascontiguousarray(rows).view(dtype).reshape(message.height, message.width, channels).astype(
        dtype.newbyteorder("="), copy=False)


class Undistorter:
    """A ``sensor_msgs/CameraInfo``'s pinhole intrinsics (``k``), and its plumb_bob distortion (``d``) removed
    from colour (bilinear) and depth (nearest: depth is never blended across edges). Other distortion models
    are refused unless their coefficients are all zero.

    CameraInfo's width and height are a claim: the undistortion maps (8 bytes a pixel) are built only at the
    first image, and only when its size is the one CameraInfo declares (a 9 MB bag declaring 20000 x 20000 asked
    for 6.9 GB); an image of another size is refused."""

    def __init__(self, info) -> None:
        K = np.asarray(info.k if hasattr(info, "k") else info.K, float).reshape(3, 3)  # ROS 1 spells K, D
        if not np.all(np.isfinite(K)) or K[0, 0] <= 0 or K[1, 1] <= 0:
            raise ImageError("CameraInfo has no intrinsics (k is zero): the camera is not calibrated")
        if not 0 < int(info.width) <= MAX_SIDE or not 0 < int(info.height) <= MAX_SIDE:
            raise ImageError(f"CameraInfo declares a {int(info.width)}x{int(info.height)} image (each side is 1 to "
                             f"{MAX_SIDE} pixels)")
        self.intrinsics = Intrinsics(int(info.width), int(info.height), float(K[0, 0]), float(K[1, 1]),
                                     float(K[0, 2]), float(K[1, 2]))
        d = np.asarray(info.d if hasattr(info, "d") else info.D, float)
        model = (info.distortion_model or "plumb_bob").lower()
        self._K, self._d, self._maps = K, None, None
        if d.size and np.any(d != 0):
            if model != "plumb_bob":
                raise ImageError(f"CameraInfo distortion model '{info.distortion_model}' is not supported "
                                 "(plumb_bob only; rectify the images first, e.g. image_proc)")
            self._d = d

    def colour(self, rgb: np.ndarray) -> np.ndarray:
        """The colour image (H, W, 3) undistorted (bilinear); ImageError if its size is not CameraInfo's."""
        maps = self._maps_for(rgb)
        return rgb if maps is None else cv2.remap(rgb, *maps, cv2.INTER_LINEAR)

    def depth(self, raw: np.ndarray) -> np.ndarray:
        """The raw depth image (H, W) undistorted (nearest); ImageError if its size is not CameraInfo's."""
        maps = self._maps_for(raw)
        return raw if maps is None else cv2.remap(raw, *maps, cv2.INTER_NEAREST)

    def _maps_for(self, image: np.ndarray):
        width, height = self.intrinsics.width, self.intrinsics.height
        if image.shape[:2] != (height, width):
            raise ImageError(f"CameraInfo is for {width}x{height} images but the image is "
                             f"{image.shape[1]}x{image.shape[0]}")
        if self._d is not None and self._maps is None:
            self._maps = cv2.initUndistortRectifyMap(self._K, self._d, None, self._K, (width, height), cv2.CV_32FC1)
        return self._maps
