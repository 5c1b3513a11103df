"""ROS bags in (``rosbags``, no ROS install): a ROS 2 ``.mcap`` or ``.db3``, a rosbag2 folder (metadata.yaml +
storage files) or a ROS 1 ``.bag`` read as a :class:`~bim2rdt.sources.FrameSource`.

Topics are found by message type (``sensor_msgs/Image`` colour or depth by its encoding, ``CompressedImage``,
``CameraInfo``, ``tf2_msgs/TFMessage`` on ``/tf`` and ``/tf_static``, ``sensor_msgs/Imu``, ``nav_msgs/Odometry``)
or named with the ``topics`` option. Frames follow REP 105: a frame's prior ``T_world_camera`` is the camera's
optical frame (the depth image's ``frame_id``) in ``map`` (else ``odom``, else the root of its TF tree), looked up
at the depth image's stamp with interpolation (:mod:`.tf`). Colour and depth are paired by header stamp within
``sync_tolerance`` (default 20 ms); a frame without a depth partner, a CameraInfo or TF within the tolerance is
dropped and kept in :attr:`RosbagSource.dropped` with its reason. Depth per REP 118: 16UC1 millimetres or 32FC1
metres. ``up`` is the IMU's measured specific force (gravity's up at rest) rotated into the camera frame.

The TF (and odometry) messages are read first, in one pass over those topics only (a few hundred bytes per
sample); images are then streamed, so memory stays flat in the bag's length.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bim2rdt.perception import Frame
from bim2rdt.sources.errors import SourceError
from bim2rdt.sources.frames import build_frame, depth_metres, intrinsics_for
from bim2rdt.sources.optional import require
from bim2rdt.sources.options import SourceOptions
from bim2rdt.sources.recording import RecordingKind
from bim2rdt.sources.ros_images import ImageError, Undistorter, colour, compressed_colour, depth, is_depth
from bim2rdt.sources.tf import TfBuffer, listed

EXTRA = "ros"
SYNC_TOLERANCE = 0.02
"""Seconds within which colour, depth and TF belong to one frame (``Settings.ros.sync_tolerance``)."""
TREE_SAMPLES = 200
"""Dynamic TF messages read at most when opening, to learn the tree (frames and parents): reading stops as soon
as the camera's frame reaches ``map``."""
TF_KEEP_S = 30.0
"""Seconds of TF kept behind the newest sample while streaming (memory flat in the bag's length)."""
CLOCK_TOLERANCE = 1.0
"""Header stamps further than this (s) from the bag's receive times mean two clocks: reported, not guessed."""
IMAGE, COMPRESSED, INFO = "sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage", "sensor_msgs/msg/CameraInfo"
TF, IMU, ODOMETRY = "tf2_msgs/msg/TFMessage", "sensor_msgs/msg/Imu", "nav_msgs/msg/Odometry"


def stamp(header) -> float:
    return header.stamp.sec + 1e-9 * header.stamp.nanosec


@dataclass(frozen=True)
class Topics:
    """The topics read: ``depth`` always; the others may be None."""

    depth: str
    colour: str | None = None
    camera_info: str | None = None
    imu: str | None = None
    odometry: str | None = None

    def as_dict(self) -> dict:
        return {k: v for k, v in self.__dict__.items() if v is not None}


class RosbagSource:
    """The frames of a bag (see the module's note), a :class:`~bim2rdt.sources.Recording` of kind ``bag``.
    ``dropped`` (after iterating): one dict per dropped frame (``time``, ``reason``, ``kind``: the reason without
    its numbers); ``drop_counts``: kinds -> counts; ``warnings``: what is off about the bag as a whole (clocks);
    ``messages``: colour (else depth) messages in the bag; ``expected_frames``: the frames that leaves after
    ``every`` and ``max_frames`` (fewer when frames are dropped)."""

    kind = RecordingKind.BAG

    def __init__(self, path: Path, options: SourceOptions) -> None:
        self.path, self.options = Path(path), options
        self.tolerance = options.sync_tolerance or SYNC_TOLERANCE
        self.rosbags = require("rosbags.highlevel", path, "ROS bags", EXTRA)
        from rosbags.typesys import Stores, get_typestore

        self.typestore = get_typestore(Stores.ROS2_HUMBLE)
        self.bag_paths = _bag_paths(self.path)
        self.dropped: list[dict] = []
        self.warnings: list[str] = []
        self._undistorters: dict[tuple, Undistorter] = {}
        self._firsts: dict[str, object] = {}
        opened = self._reader()
        reader = opened.__enter__()
        try:
            self.topics = self._topics(reader)
            self.camera_frame = self._camera_frame(reader)
            self.tf = self._read_tf(reader)
            self.messages = self._count(reader, self.topics.colour or self.topics.depth)
            self._check_tf()
            self.world_frame = self.tf.root(self.camera_frame) if self.tf else None
            """The frame the priors are in: map, else odom, else the camera tree's root (None: no TF)."""
            self._firsts.clear()  # a first image is a frame's worth of memory
        except BaseException as error:
            opened.__exit__(type(error), error, None)
            raise
        self._opened = opened  # the first iteration reads on (opening a rosbag2 folder parses its metadata.yaml)

    @property
    def expected_frames(self) -> int:
        """The frames left of ``messages`` after ``every`` and ``max_frames`` (an upper bound: drops aside)."""
        kept = -(-self.messages // (self.options.every or 1))
        return kept if self.options.max_frames is None else min(kept, self.options.max_frames)

    @property
    def drop_counts(self) -> dict[str, int]:
        """{kind: number} of the frames dropped."""
        return dict(Counter(d["kind"] for d in self.dropped))

    # -- opening ---------------------------------------------------------------------------------------------

    def _reader(self):
        try:
            reader = self.rosbags.AnyReader(self.bag_paths, default_typestore=self.typestore)
            return _Opened(reader, self.path)
        except Exception as error:  # rosbags raises many types for a damaged file
            raise SourceError(self.path, f"not a readable bag ({_first_line(error)})") from None

    def _topics(self, reader) -> Topics:
        named = dict(self.options.topics or {})
        by_topic = {c.topic: c.msgtype for c in reader.connections}
        for role, topic in named.items():
            if topic not in by_topic:
                raise SourceError(self.path, f"no topic {topic} (for {role}) in the bag (topics: "
                                             f"{', '.join(sorted(by_topic))})")
        images = [t for t, m in sorted(by_topic.items()) if m in (IMAGE, COMPRESSED)]
        if not images and not named.get("depth"):
            raise SourceError(self.path, "no image topics (sensor_msgs/Image or CompressedImage) in the bag (topics: "
                                         f"{', '.join(sorted(by_topic)) or 'none'})")
        encodings = {t: self._first(reader, t) for t in images if by_topic[t] == IMAGE}
        depths = [t for t, e in encodings.items() if e is not None and is_depth(e.encoding)]
        colours = [t for t in images if t not in depths]
        depth_topic = named.get("depth") or _preferred(depths, ("aligned", "depth"))
        if depth_topic is None:
            found = ", ".join(f"{t} ({encodings[t].encoding if encodings.get(t) else 'compressed'})"
                              for t in images)
            raise SourceError(self.path, f"no depth image topic (16UC1 or 32FC1) among the image topics: {found}")
        colour_topic = named.get("colour") or _preferred(colours, ("color", "colour", "rgb"))
        infos = [t for t, m in by_topic.items() if m == INFO]
        info = named.get("camera_info") or _preferred(infos, (_namespace(depth_topic), _namespace(colour_topic or "")))
        if info is None and self.options.intrinsics is None:
            raise SourceError(self.path, f"depth {depth_topic} has no sensor_msgs/CameraInfo in the bag: give the "
                                         "intrinsics, or record the camera_info topic")
        imu = named.get("imu") or _preferred([t for t, m in by_topic.items() if m == IMU], ("imu",))
        odometry = named.get("odometry") or _preferred([t for t, m in by_topic.items() if m == ODOMETRY], ("odom",))
        return Topics(depth_topic, colour_topic, info, imu, odometry)

    def _first(self, reader, topic: str):
        """The topic's first message (read once: opening asks for it twice), its clock checked."""
        if topic not in self._firsts:
            self._firsts[topic] = self._read_first(reader, topic)
        return self._firsts[topic]

    def _read_first(self, reader, topic: str):
        for connection, log_time, raw in reader.messages([c for c in reader.connections if c.topic == topic]):
            message = reader.deserialize(raw, connection.msgtype)
            header_time = self._stamp(topic, message)
            if abs(header_time - log_time * 1e-9) > CLOCK_TOLERANCE:
                self._clock_warning(topic, header_time - log_time * 1e-9)
            return message
        return None

    def _stamp(self, topic: str, message) -> float:
        """The message's header stamp (s); a negative one (a clock never set: the events would be dated before
        1970) is refused, not replaced by a guess (decision 0036)."""
        when = stamp(message.header)
        if when < 0:
            raise SourceError(self.path, f"{topic}: header stamp {when:.3f} s is before 1970: the sensor's clock was "
                                         "not set; re-stamp the recording (e.g. with its receive times) and verify "
                                         "that")
        return when

    def _clock_warning(self, topic: str, offset: float) -> None:
        warning = (f"clocks disagree: {topic}'s header stamps are {offset:+.1f} s from the bag's receive times; "
                   "frames are synced on header stamps as recorded (no offset guessed)")
        if not any(w.startswith(f"clocks disagree: {topic}'") for w in self.warnings):
            self.warnings.append(warning)

    def _read_tf(self, reader) -> TfBuffer:
        """The TF tree: all of /tf_static and the first ``TREE_SAMPLES`` dynamic transforms (the frames and who is
        whose parent; the dynamic samples are read again while streaming)."""
        buffer = TfBuffer(self.tolerance)
        connections = self._tf_connections(reader)
        static = [c for c in connections if c.topic.endswith("tf_static")]
        for connection, _, raw in reader.messages(static):
            self._add(buffer, reader.deserialize(raw, connection.msgtype), connection, static=True)
        self.static_tf = [(parent, child, T) for parent, child, T in buffer.statics()]
        dynamic = [c for c in connections if c not in static]
        for count, (connection, _, raw) in enumerate(reader.messages(dynamic)):
            self._add(buffer, reader.deserialize(raw, connection.msgtype), connection)
            if count >= TREE_SAMPLES or (count >= len(dynamic) and buffer.root(self.camera_frame) == "map"):
                break
        return buffer

    def _tf_connections(self, reader) -> list:
        """/tf and /tf_static, and the odometry topic when there is no /tf (REP 105's odom -> base_link)."""
        tf = [c for c in reader.connections if c.msgtype == TF]
        if self.topics.odometry and not any(not c.topic.endswith("tf_static") for c in tf):
            tf += [c for c in reader.connections if c.topic == self.topics.odometry]
        return tf

    @staticmethod
    def _add(buffer: TfBuffer, message, connection, static: bool = False) -> float | None:
        """A TFMessage's or an Odometry's transforms into ``buffer``; the latest stamp (None: static)."""
        if connection.msgtype == ODOMETRY:
            p, q = message.pose.pose.position, message.pose.pose.orientation
            when = stamp(message.header)
            buffer.add(message.header.frame_id, message.child_frame_id, (p.x, p.y, p.z), (q.x, q.y, q.z, q.w), when)
            return when
        latest = None
        for transform in message.transforms:
            t, q = transform.transform.translation, transform.transform.rotation
            when = None if static else stamp(transform.header)
            buffer.add(transform.header.frame_id, transform.child_frame_id, (t.x, t.y, t.z), (q.x, q.y, q.z, q.w),
                       when)
            latest = when if latest is None or (when is not None and when > latest) else latest
        return latest

    def _camera_frame(self, reader) -> str:
        message = self._first(reader, self.topics.depth)
        if message is None:
            raise SourceError(self.path, f"{self.topics.depth} holds no messages")
        if self.topics.colour:
            self._first(reader, self.topics.colour)
        return message.header.frame_id.lstrip("/")

    def _count(self, reader, topic: str) -> int:
        return sum(c.msgcount for c in reader.connections if c.topic == topic)

    def _check_tf(self) -> None:
        if self.tf and self.camera_frame not in self.tf.frames:
            raise SourceError(self.path, f"the TF tree has no path to the camera frame '{self.camera_frame}' "
                                         f"(frames: {listed(self.tf.frames)})")
        loop = self.tf.cycle(self.camera_frame) if self.tf else None
        if loop is not None:
            raise SourceError(self.path, f"the TF frames above the camera form a cycle ({' -> '.join(loop)}): TF must "
                                         "be a tree, each frame with one parent")


    # -- streaming -------------------------------------------------------------------------------------------

    def __iter__(self) -> Iterator[Frame]:
        self.dropped = []
        every, limit = self.options.every or 1, self.options.max_frames
        emitted = paired = 0
        opened, self._opened = self._opened or self._reader(), None
        with opened as reader:
            for item in self._pairs(reader):
                if isinstance(item, dict):
                    self.dropped.append(item)
                    continue
                paired += 1
                if (paired - 1) % every:
                    continue
                frame = self._frame(reader, *item)
                if isinstance(frame, dict):
                    self.dropped.append(frame)
                    continue
                yield frame
                emitted += 1
                if limit is not None and emitted >= limit:
                    return

    def _pairs(self, reader) -> Iterator:
        """(colour message or None, depth message, CameraInfo or None, latest IMU or None) per frame, or a drop
        (a dict with time and reason), in stamp order. TF streams in the same pass: a pair waits until TF has a
        sample ``sync_tolerance`` past its stamp (or the bag ends), so its prior can be interpolated."""
        for item in self._synced(reader):
            yield item

    def _synced(self, reader) -> Iterator:
        topics = self.topics
        tf_connections = [c for c in self._tf_connections(reader) if not c.topic.endswith("tf_static")]
        self.tf = TfBuffer(self.tolerance)
        for parent, child, T in self.static_tf:
            self.tf.add_matrix(parent, child, T)
        wanted = [c for c in reader.connections if c.topic in {topics.depth, topics.colour, topics.camera_info,
                                                               topics.imu}] + tf_connections
        colours: list = []
        depths: list = []
        waiting: list = []
        state = {"info": None, "imu": None, "tf": -math.inf}
        last_info = None
        for connection, log_time, raw in reader.messages(wanted):
            if connection.topic == topics.camera_info:
                if last_info is None or not _same_after_stamp(raw, last_info):
                    state["info"], last_info = reader.deserialize(raw, connection.msgtype), raw
                continue
            message = reader.deserialize(raw, connection.msgtype)
            if connection in tf_connections:
                latest = self._add(self.tf, message, connection)
                state["tf"] = max(state["tf"], latest if latest is not None else -math.inf)
                while waiting and (isinstance(waiting[0], dict) or
                                   _stamp_of(waiting[0]) + self.tolerance <= state["tf"]):
                    yield waiting.pop(0)
                self.tf.forget_before(state["tf"] - TF_KEEP_S)
                continue
            if connection.topic == topics.imu:
                state["imu"] = message
                continue
            when = stamp(message.header)
            if abs(when - log_time * 1e-9) > CLOCK_TOLERANCE:
                self._clock_warning(connection.topic, when - log_time * 1e-9)
            if connection.topic == topics.depth:
                if topics.colour is None:
                    waiting.append((None, message, state["info"], state["imu"]))
                    continue
                depths.append((when, message))
            else:
                colours.append((when, message))
            waiting.extend(self._matched(colours, depths, state, final=False))
            if not tf_connections:
                yield from waiting
                waiting.clear()
        waiting.extend(self._matched(colours, depths, state, final=True))
        yield from waiting

    def _matched(self, colours: list, depths: list, state: dict, final: bool) -> Iterator:
        while colours:
            when, message = colours[0]
            if not final and not (depths and depths[-1][0] >= when + self.tolerance):
                return  # a closer depth may still come
            nearest = min(range(len(depths)), key=lambda i: abs(depths[i][0] - when), default=None)
            colours.pop(0)
            if nearest is None or abs(depths[nearest][0] - when) > self.tolerance:
                reason = f"no depth image within {self.tolerance * 1000:.0f} ms"
                yield _drop(when, reason, reason)
                continue
            depth_message = depths[nearest][1]
            del depths[: nearest + 1]
            yield message, depth_message, state["info"], state["imu"]

    def _frame(self, reader, colour_message, depth_message, info, imu) -> Frame | dict:
        when = self._stamp(self.topics.depth, depth_message)
        name = f"{self.topics.depth}@{when:.3f}"
        raw, units = self._image(self.topics.depth, depth, depth_message)
        rgb = None
        if colour_message is not None:
            rgb = self._image(self.topics.colour, compressed_colour if hasattr(colour_message, "format") else colour,
                              colour_message)
        if info is None and self.options.intrinsics is None:
            return _drop(when, f"no CameraInfo on {self.topics.camera_info} before this frame", "no CameraInfo")
        if rgb is not None and rgb.shape[:2] != raw.shape:
            raise SourceError(self.path, f"colour {self.topics.colour} is {rgb.shape[1]}x{rgb.shape[0]} but depth "
                                         f"{self.topics.depth} is {raw.shape[1]}x{raw.shape[0]}: record the depth "
                                         "aligned to colour (aligned_depth_to_color), or name only the depth topic")
        found = None
        if info is not None:
            undistort = self._undistorter(info)
            try:  # the image's size is checked against CameraInfo's before any map is built
                raw = undistort.depth(raw)
                rgb = None if rgb is None else undistort.colour(rgb)
            except ImageError as error:
                raise SourceError(self.path, f"{self.topics.camera_info}: {error}") from None
            found = undistort.intrinsics
        intrinsics = intrinsics_for(self.path, self.options, raw.shape[1], raw.shape[0], found)
        prior = None
        if self.world_frame is not None:
            prior = self.tf.lookup(self.world_frame, self.camera_frame, when)
            if isinstance(prior, str):
                return _drop(when, prior, "no TF within tolerance")
        if self.options.depth_scale is not None:  # the caller overrides REP 118's units: check them as any reader
            try:
                depth_m = depth_metres(name, raw, self.options.depth_scale)
            except SourceError as error:
                return _drop(when, error.problem, "depth out of range")
        else:  # REP 118 fixes the units (16UC1 mm, 32FC1 m); the Frame still refuses a millimetre-looking median
            if units == 1.0:
                depth_m, any_valid = raw, bool(np.any(raw > 0))
            else:  # integer millimetres: one pass to metres; a zero is no return
                depth_m, any_valid = np.multiply(raw, np.float32(1.0 / units), dtype=np.float32), bool(raw.any())
            if not any_valid:
                return _drop(when, "the depth image has no valid pixel (all 0 or NaN)", "no valid depth")
        return build_frame(self.path, rgb, depth_m, intrinsics, self.options, time=when, prior=prior,
                           up=self._up(imu, when, prior), source=name)

    def _image(self, topic: str, decode, message):
        """``decode(message)``, or :class:`SourceError` naming ``topic`` when it is not a readable image."""
        try:
            return decode(message)
        except ImageError as error:
            raise SourceError(self.path, f"{topic}: {error}") from None

    def _undistorter(self, info) -> Undistorter:
        """The CameraInfo's :class:`Undistorter`, built once per distinct calibration (a camera publishes the same
        one with every frame; building it maps the whole image when it has distortion)."""
        key = (int(info.width), int(info.height), info.distortion_model,
               tuple(np.asarray(info.k if hasattr(info, "k") else info.K, float).tolist()),
               tuple(np.asarray(info.d if hasattr(info, "d") else info.D, float).tolist()))
        cached = self._undistorters.get(key)
        if cached is None:
            try:
                cached = self._undistorters[key] = Undistorter(info)
            except ImageError as error:
                raise SourceError(self.path, f"{self.topics.camera_info}: {error}") from None
        return cached

    def _up(self, imu, when: float, T_root_camera: np.ndarray | None = None) -> np.ndarray | None:
        """Gravity's up in the camera frame from the IMU's specific force (at rest it points up), rotated by TF."""
        if imu is None:
            return None
        a = imu.linear_acceleration
        up_imu = np.array([a.x, a.y, a.z])
        if not np.all(np.isfinite(up_imu)) or np.linalg.norm(up_imu) < 1.0:
            return None
        imu_frame = imu.header.frame_id.lstrip("/")
        if imu_frame == self.camera_frame:
            return up_imu / np.linalg.norm(up_imu)
        root = self.world_frame
        if root is None:
            return None
        T_root_imu = self.tf.lookup(root, imu_frame, when)
        if T_root_camera is None:
            T_root_camera = self.tf.lookup(root, self.camera_frame, when)
        if isinstance(T_root_imu, str) or isinstance(T_root_camera, str):
            return None
        up = T_root_camera[:3, :3].T @ T_root_imu[:3, :3] @ up_imu
        return up / np.linalg.norm(up)


class _Opened:
    """The AnyReader opened as a context, any rosbags failure while reading turned into one line."""

    def __init__(self, reader, path: Path) -> None:
        self.reader, self.path = reader, path

    def __enter__(self):
        if not getattr(self, "guarded", None):
            try:
                self.reader.open()
            except Exception as error:
                raise SourceError(self.path, f"not a readable bag ({_first_line(error)})") from None
            self.guarded = _Guarded(self.reader, self.path)
        return self.guarded

    def __exit__(self, kind, error, trace) -> None:
        self.guarded = None
        try:
            self.reader.close()
        except Exception:
            pass
        if error is not None and not isinstance(error, (SourceError, GeneratorExit)) and _is_bag_error(error):
            raise SourceError(self.path, f"the bag is damaged ({_first_line(error)})") from None


class _Guarded:
    """AnyReader's connections, messages and deserialize, with damage while streaming as a :class:`SourceError`."""

    def __init__(self, reader, path: Path) -> None:
        self.reader, self.path = reader, path
        self.connections = reader.connections

    def messages(self, connections):
        if not connections:
            return
        try:
            yield from self.reader.messages(connections)
        except (SourceError, GeneratorExit):
            raise
        except Exception as error:
            raise SourceError(self.path, f"the bag is damaged or truncated ({_first_line(error)})") from None

    def deserialize(self, raw, msgtype: str):
        try:
            return self.reader.deserialize(raw, msgtype)
        except Exception as error:
            raise SourceError(self.path, f"a {msgtype} message does not decode ({_first_line(error)})") from None


STAMP_END = 12
"""Bytes up to the end of a message's header stamp, in ROS 2 CDR (4 encapsulation bytes, sec, nanosec) and in
ROS 1 (seq, sec, nsec) alike: two messages equal after it differ only in their stamps."""


def _same_after_stamp(raw, previous) -> bool:
    """Whether serialized message ``raw`` equals ``previous`` but for its header stamp (a CameraInfo repeated with
    every frame: its calibration is decoded once)."""
    return len(raw) == len(previous) and memoryview(raw)[STAMP_END:] == memoryview(previous)[STAMP_END:]


def _stamp_of(pair) -> float:
    return stamp(pair[1].header)


def _is_bag_error(error: BaseException) -> bool:
    return type(error).__module__.startswith("rosbags")


def _bag_paths(path: Path) -> list[Path]:
    """What AnyReader opens: a rosbag2 folder (needs metadata.yaml), a storage file, or a ROS 1 bag."""
    if path.is_dir() and not (path / "metadata.yaml").is_file():
        storage = sorted([*path.glob("*.db3"), *path.glob("*.mcap")])
        raise SourceError(path, "a rosbag2 folder without metadata.yaml" + (
            f": open its storage file {storage[0].name} directly (or restore metadata.yaml, e.g. ros2 bag reindex)"
            if storage else ""))
    return [path]


def _preferred(topics: list[str], words) -> str | None:
    """The topic whose name holds the earliest of ``words`` (else the first topic)."""
    if not topics:
        return None
    for word in words:
        if word:
            match = [t for t in topics if word in t]
            if match:
                return match[0]
    return topics[0]


def _namespace(topic: str) -> str:
    return topic.rsplit("/", 1)[0] + "/" if "/" in topic.strip("/") else ""


def _drop(when: float, reason: str, kind: str) -> dict:
    """A dropped frame: its stamp (s), why, and the kind summaries count (the reason without its numbers)."""
    return {"time": when, "reason": reason, "kind": kind}


def _first_line(error: BaseException) -> str:
    text = str(error).strip().splitlines()
    return f"{type(error).__name__}: {text[0]}" if text else type(error).__name__


