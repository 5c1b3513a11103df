"""Azure Kinect ``.mkv`` recordings, read with PyAV (the ``sensors`` extra; no Azure Kinect SDK needed).

- Depth (16-bit millimetres) becomes metres, undistorted to the depth camera's pinhole (nearest neighbour, so no
  depth is invented across an edge); the frame's intrinsics are that pinhole's, from the calibration attached to
  the file (or ``calibration=`` a JSON file). Given ``intrinsics=`` instead, the depth is taken as already pinhole.
- Colour (1280x720 MJPEG and other modes) is registered onto the depth image: each depth pixel's point is moved
  into the colour camera with the calibration's extrinsics and projected with its lens; pixels without depth are
  black. Without a colour track (or without a calibration to register it) the frame gets a grey stand-in.
- The IMU track gives ``up``: the mean corrected accelerometer reading within ``IMU_WINDOW_S`` of the frame,
  rotated into the depth camera (see :mod:`bim2rdt.sources.k4a`). ``time`` is the device clock in seconds.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np

from bim2rdt.perception import Frame
from bim2rdt.sources import budget, k4a
from bim2rdt.sources.errors import SourceError
from bim2rdt.sources.frames import build_frame, depth_metres, intrinsics_for
from bim2rdt.sources.optional import require
from bim2rdt.sources.options import SourceOptions

IMU_WINDOW_S = 0.5
"""Accelerometer samples this close (s) to a frame are averaged for its ``up``; none that close: no ``up``."""
BYTES_PER_PIXEL = 96
"""What one depth frame allocates per depth pixel (bytes): raw and undistorted 16-bit depth, the maps (8), metres
(4), the registered colour, the frame's own arrays and the localization's per-pixel points."""
PAIR_TOLERANCE_S = 0.017
"""A colour image belongs to a depth image when their timestamps differ by at most this (half a 30 fps period)."""


class AzureKinectMkv:
    """A :class:`~bim2rdt.sources.FrameSource` over an Azure Kinect recording's depth frames."""

    def __init__(self, path: Path, options: SourceOptions) -> None:
        self.path, self.options = Path(path), options
        self.av = require("av", path, "an Azure Kinect .mkv")
        with self._open() as container:
            self.depth_index = self._track(container, "DEPTH").index
            color = self._track(container, "COLOR", required=False)
            self.color_index = None if color is None else color.index
            imu = self._track(container, "IMU", required=False)
            self.imu_index = None if imu is None else imu.index
            self.start_s = int(container.metadata.get("K4A_START_OFFSET_NS", 0)) * 1e-9
            depth = container.streams[self.depth_index]
            self.depth_mode = depth.metadata.get("K4A_DEPTH_MODE")
            self.depth_size = (depth.codec_context.width, depth.codec_context.height)
            self._check_sizes(container)
            self.calibration = self._calibration(container)

    def __iter__(self) -> Iterator[Frame]:
        depth_lens = self._depth_lens()
        intrinsics = intrinsics_for(self.path, self.options, *self.depth_size,
                                    None if depth_lens is None else depth_lens.intrinsics)
        undistort = None if (depth_lens is None or self.options.intrinsics is not None) else _undistort_maps(depth_lens)
        imu = self._imu()
        up_of = self._up_reader(imu)
        count = 0
        for time_s, depth_raw, rgb in self._captures():
            if undistort is not None:
                depth_raw = cv2.remap(depth_raw, *undistort, cv2.INTER_NEAREST)
            depth = depth_metres(self.path, depth_raw, self.options.depth_scale or 1000.0)
            colour = None if rgb is None else self._registered(rgb, depth, intrinsics, depth_lens)
            yield build_frame(self.path, colour, depth, intrinsics, self.options, time=time_s, up=up_of(time_s),
                              source=f"{self.path.name}@{time_s:.6f}")
            count += 1
            if self.options.max_frames is not None and count >= self.options.max_frames:
                return
        if count == 0:
            raise SourceError(self.path, "the DEPTH track holds no frames")

    # ---- tracks and calibration

    def _open(self):
        try:
            return self.av.open(str(self.path))
        except Exception as error:  # PyAV raises its own error classes per FFmpeg code
            raise SourceError(self.path, f"not a readable Matroska file ({type(error).__name__})") from None

    def _track(self, container, title: str, required: bool = True):
        for stream in container.streams:
            if stream.metadata.get("title") == title or f"K4A_{title}_TRACK" in stream.metadata:
                return stream
        if required:
            raise SourceError(self.path, f"no {title} track: not an Azure Kinect recording with depth")
        return None

    def _check_sizes(self, container) -> None:
        """The tracks' declared image sizes are claims: sides in range, one raw 16-bit depth image within the
        file, and a frame's arrays within the memory cap (the undistortion maps alone take 8 bytes a pixel)."""
        width, height = self.depth_size
        budget.check_image_side(self.path, width, height, "the DEPTH track")
        if self.color_index is not None:
            colour = container.streams[self.color_index].codec_context
            budget.check_image_side(self.path, colour.width, colour.height, "the COLOR track")
        budget.check_claim(self.path, width * height * 2, f"{width}x{height} 16-bit depth images")
        budget.check_memory(self.path, width * height * BYTES_PER_PIXEL, f"{width}x{height} depth images")

    def _calibration(self, container) -> dict | None:
        if self.options.calibration is not None:
            text, where = _read_text(self.options.calibration), str(self.options.calibration)
        else:
            attached = [s for s in container.streams if s.type == "attachment"
                        and "K4A_CALIBRATION_FILE" in s.metadata]
            if not attached:
                return None
            text, where = bytes(attached[0].data).decode("utf-8", "replace"), "the attached calibration.json"
        try:
            calibration = json.loads(text)
            k4a.camera(calibration, "Depth")
            return calibration
        except (ValueError, KeyError, TypeError) as error:
            raise SourceError(self.path, f"{where} is not an Azure Kinect calibration ({error})") from None

    def _depth_lens(self) -> k4a.Lens | None:
        if self.calibration is None:
            return None
        try:
            return k4a.depth_lens(self.calibration, self.depth_mode, self.depth_size)
        except (KeyError, IndexError) as error:
            raise SourceError(self.path, f"the calibration does not describe the depth images ({error})") from None

    # ---- reading

    def _captures(self) -> Iterator[tuple[float, np.ndarray, np.ndarray | None]]:
        """(device time s, raw depth (H, W) uint16, colour (h, w, 3) uint8 or None) per depth image, in order."""
        pending: list[tuple[float, np.ndarray]] = []
        colours: list[tuple[float, np.ndarray]] = []
        with self._open() as container:
            streams = [container.streams[self.depth_index]]
            if self.color_index is not None:
                streams.append(container.streams[self.color_index])
            for packet in container.demux(*streams):
                if packet.pts is None:
                    continue
                time_s = float(packet.pts * packet.time_base) + self.start_s
                yield from _paired(pending, colours, before=time_s - PAIR_TOLERANCE_S)
                for frame in _decoded(packet, self.path):
                    if packet.stream.index == self.depth_index:
                        pending.append((time_s, frame.to_ndarray()))
                    else:
                        colours = [*colours[-2:], (time_s, frame.to_ndarray(format="rgb24"))]
        yield from _paired(pending, colours, before=np.inf)

    def _imu(self) -> list[tuple[float, np.ndarray]]:
        if self.imu_index is None:
            return []
        samples = []
        with self._open() as container:
            for packet in container.demux(container.streams[self.imu_index]):
                if packet.size:
                    try:
                        samples += k4a.imu_samples(bytes(packet))
                    except ValueError as error:
                        raise SourceError(self.path, f"IMU track: {error}") from None
        return samples

    def _up_reader(self, imu: list[tuple[float, np.ndarray]]):
        accelerometer = None
        if imu and self.calibration is not None:
            try:
                accelerometer = k4a.accelerometer(self.calibration)
            except KeyError:
                accelerometer = None
        times = np.array([t for t, _ in imu])
        readings = np.array([a for _, a in imu]).reshape(-1, 3)

        def up_at(time_s: float) -> np.ndarray | None:
            if accelerometer is None:
                return None
            near = np.abs(times - time_s) <= IMU_WINDOW_S
            return accelerometer.up_in_depth(readings[near]) if near.any() else None
        return up_at

    def _registered(self, rgb: np.ndarray, depth: np.ndarray, intrinsics, depth_lens) -> np.ndarray | None:
        if self.calibration is None or depth_lens is None:
            return None
        try:
            colour_lens = k4a.color_lens(self.calibration, (rgb.shape[1], rgb.shape[0]))
        except KeyError as error:
            raise SourceError(self.path, f"the calibration does not describe the colour images ({error})") from None
        return colour_on_depth(rgb, depth, intrinsics, colour_lens)


def colour_on_depth(rgb: np.ndarray, depth: np.ndarray, intrinsics, colour_lens: k4a.Lens) -> np.ndarray:
    """The colour image (h, w, 3) resampled onto the depth image's pixels (H, W, 3): each depth pixel's point
    moved into the colour camera (``p_colour = R p_depth + t``) and projected with its lens; black where there is
    no depth or the point falls outside the colour image."""
    valid = np.isfinite(depth) & (depth > 0)
    points = intrinsics.pixel_rays()[valid] * depth[valid, None].astype(np.float64)
    in_colour = points @ colour_lens.R.T + colour_lens.t
    in_colour[in_colour[:, 2] <= 0] = np.nan  # behind the colour camera: nowhere in its image
    uv, _ = cv2.projectPoints(in_colour.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), colour_lens.K,
                              colour_lens.distortion)
    map_u = np.full(depth.shape, -1.0, np.float32)
    map_v = np.full(depth.shape, -1.0, np.float32)
    map_u[valid], map_v[valid] = uv.reshape(-1, 2).T
    return cv2.remap(rgb, np.nan_to_num(map_u, nan=-1.0), np.nan_to_num(map_v, nan=-1.0), cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0))


def _undistort_maps(lens: k4a.Lens) -> tuple[np.ndarray, np.ndarray]:
    size = (lens.intrinsics.width, lens.intrinsics.height)
    return cv2.initUndistortRectifyMap(lens.K, lens.distortion, None, lens.K, size, cv2.CV_32FC1)


def _paired(pending: list, colours: list, before: float) -> Iterator[tuple[float, np.ndarray, np.ndarray | None]]:
    """Depth images older than ``before`` with the colour image closest in time (within the tolerance), removed
    from ``pending``."""
    while pending and pending[0][0] < before:
        time_s, depth = pending.pop(0)
        close = [(abs(t - time_s), rgb) for t, rgb in colours if abs(t - time_s) <= PAIR_TOLERANCE_S]
        yield time_s, depth, min(close, key=lambda c: c[0])[1] if close else None


def _decoded(packet, path) -> list:
    try:
        return list(packet.decode())
    except Exception as error:  # FFmpeg decode errors come as PyAV's own classes
        raise SourceError(path, f"a {packet.stream.metadata.get('title', 'video')} frame does not decode "
                                f"({type(error).__name__})") from None


def _read_text(path: Path) -> str:
    try:
        return Path(path).read_text()
    except OSError as error:
        raise SourceError(path, f"cannot read the calibration ({error.strerror or error})") from None
