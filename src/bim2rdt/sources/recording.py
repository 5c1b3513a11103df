"""What a path holds, decided in one place: ``open_recording(path, **options)`` returns a :class:`Recording` of
camera frames, of one scan, or of a ROS bag, already subsampled (``every``, ``max_frames``).

The rule, in order:

1. a ROS bag (:func:`is_rosbag`): a ``.mcap``, ``.db3`` or ``.bag`` file, or a rosbag2 folder;
2. a scan: a ``.ply``, ``.las``, ``.laz`` or ``.e57`` file, or a ``.pcd`` that is not organised (its header's
   ``HEIGHT`` is 1: a laser scan, not a camera image), read whole as one :class:`~bim2rdt.sources.Cloud`;
3. camera frames: whatever :func:`~bim2rdt.sources.open_source` reads (an organised ``.pcd``, an ``.mkv``, a
   TUM, PNG-pair or PCL grabber folder).

A :class:`Recording` also says what a consumer needs beyond its items, as declared attributes rather than
optional ones to probe: the frames the source dropped (``dropped``, each with its ``kind``), its warnings about
the recording as a whole, and how many items it will yield when it knows (``expected_frames``).
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Iterator
from enum import Enum
from pathlib import Path
from typing import Protocol, runtime_checkable

from bim2rdt.perception import Frame
from bim2rdt.sources.cloud import Cloud, read_cloud
from bim2rdt.sources.errors import SourceError
from bim2rdt.sources.options import SourceOptions, parse_options
from bim2rdt.sources.pcd_frame import pcd_is_organised
from bim2rdt.sources.source import FILE_READERS, open_source

BAG_SUFFIXES = (".mcap", ".db3", ".bag")
"""A ROS 2 storage file (MCAP, SQLite) or a ROS 1 bag."""
SCAN_SUFFIXES = (".ply", ".las", ".laz", ".e57")
"""Scan formats that are always one registered cloud (a ``.pcd`` is a scan only when it is not organised)."""
FOLDER_KINDS = "TUM (rgb.txt + depth.txt), colour + depth PNG pairs, PCL grabber TIFFs, rosbag2"
"""The folders the readers know (``FOLDER_READERS``), in words for messages."""


class RecordingKind(str, Enum):
    """What a recording holds: camera frames, one scan, or a ROS bag's frames."""

    FRAMES = "frames"
    SCAN = "scan"
    BAG = "bag"


@runtime_checkable
class Recording(Protocol):
    """A source as a consumer (verify) reads it: its items in order (each a :class:`~bim2rdt.perception.Frame`,
    or a :class:`~bim2rdt.sources.Cloud` for a scan), and what it reports.

    ``kind``: a :class:`RecordingKind`; ``expected_frames``: the items it will yield when known (after
    subsampling), else None; ``dropped`` (read after iterating): one ``{"time", "reason", "kind"}`` per frame the
    source dropped (``kind`` is the reason without its numbers, what summaries count); ``warnings``: what is off
    about the recording as a whole (a bag whose clocks disagree)."""

    kind: RecordingKind
    expected_frames: int | None
    dropped: list[dict]
    warnings: list[str]

    def __iter__(self) -> Iterator[Frame | Cloud]: ...


class FrameRecording:
    """A frame reader's frames, every ``every``-th, at most ``max_frames``: a :class:`Recording` that drops
    nothing and has no warnings."""

    kind = RecordingKind.FRAMES

    def __init__(self, frames: Iterable[Frame], every: int = 1, max_frames: int | None = None,
                 expected_frames: int | None = None) -> None:
        self.frames, self.every, self.max_frames = frames, every, max_frames
        self.expected_frames = expected_frames
        self.dropped: list[dict] = []
        self.warnings: list[str] = []

    def __iter__(self) -> Iterator[Frame]:
        stop = None if self.max_frames is None else self.max_frames * self.every
        return itertools.islice(iter(self.frames), 0, stop, self.every)


class ScanRecording:
    """One scan as a :class:`Recording` of one :class:`~bim2rdt.sources.Cloud`."""

    kind = RecordingKind.SCAN
    expected_frames = 1

    def __init__(self, cloud: Cloud) -> None:
        self.cloud = cloud
        self.dropped: list[dict] = []
        self.warnings: list[str] = []

    def __iter__(self) -> Iterator[Cloud]:
        return iter([self.cloud])


def as_recording(items: Recording | Iterable) -> Recording:
    """``items`` as a :class:`Recording`: itself when it is one, else a :class:`FrameRecording` of it (a list of
    frames or clouds a caller built: nothing dropped, no warnings).

    Args:
        items: A recording, or any iterable of frames or clouds.

    Returns:
        The recording.
    """
    if isinstance(items, Recording):
        return items
    return FrameRecording(items, expected_frames=len(items) if isinstance(items, (list, tuple)) else None)


def open_recording(path: str | Path, **options: object) -> Recording:
    """Open what ``path`` holds (see the module's note for the rule) as a :class:`Recording`.

    Args:
        path: A bag, a scan file, or a camera recording (file or folder).
        **options: The fields of :class:`~bim2rdt.sources.SourceOptions`. ``every`` and ``max_frames``
            subsample every kind; ``topics`` is for bags only; a scan takes ``depth_scale`` (its units per metre)
            and ``depth_correction``, and refuses the camera's options (``intrinsics``, ``calibration``).

    Returns:
        The recording, iterable for its frames or its one cloud.

    Raises:
        SourceError: A path that does not exist, a format no reader knows (the message lists every reader,
            scans included), an option the kind does not take, or a recording its reader refuses at once.
    """
    path = Path(path)
    checked = parse_options(path, options)
    if not path.exists():
        raise SourceError(path, "no such file or folder")
    kind = recording_kind(path)
    if checked.topics is not None and kind is not RecordingKind.BAG:
        raise SourceError(path, f"topics (verify --topics) are for ROS bags ({', '.join(BAG_SUFFIXES)}, a rosbag2 "
                                f"folder); this is {'a scan' if kind is RecordingKind.SCAN else 'a camera recording'}")
    if kind is RecordingKind.SCAN:
        return _scan(path, checked)
    if kind is RecordingKind.BAG:
        return open_source(path, **options)  # a RosbagSource is a Recording: it subsamples as it pairs
    reader = open_source(path, **{**options, "every": None, "max_frames": None})
    return FrameRecording(reader, checked.every or 1, checked.max_frames)


def recording_kind(path: Path) -> RecordingKind:
    """The kind of recording at an existing ``path`` (see the module's note).

    Args:
        path: An existing file or folder.

    Returns:
        Its kind.

    Raises:
        SourceError: A file whose extension no reader knows, naming every reader (frames and scans).
    """
    if is_rosbag(path):
        return RecordingKind.BAG
    suffix = path.suffix.lower()
    if path.is_file() and (suffix in SCAN_SUFFIXES or (suffix == ".pcd" and not pcd_is_organised(path))):
        return RecordingKind.SCAN
    if path.is_file() and suffix not in FILE_READERS:
        raise SourceError(path, f"no reader for '{path.suffix or path.name}' files (camera frames: "
                                f"{', '.join(sorted(set(FILE_READERS) - set(BAG_SUFFIXES)))}; ROS bags: "
                                f"{', '.join(BAG_SUFFIXES)}; scans: {', '.join(SCAN_SUFFIXES)}, an unorganised .pcd; "
                                f"or a folder: {FOLDER_KINDS})")
    return RecordingKind.FRAMES


def is_rosbag(path: Path) -> bool:
    """The one rule for a ROS bag: a ``.mcap``, ``.db3`` or ``.bag`` file, or a folder that is a rosbag2 folder
    (:func:`is_rosbag_folder`).

    Args:
        path: A file or folder.

    Returns:
        True when it is read as a bag.
    """
    if path.is_dir():
        return is_rosbag_folder(path)
    return path.suffix.lower() in BAG_SUFFIXES


def is_rosbag_folder(path: Path) -> bool:
    """A rosbag2 folder: metadata.yaml, or .db3/.mcap storage files (the reader then asks for metadata.yaml).

    Args:
        path: A folder.

    Returns:
        True when it is read as a bag.
    """
    return (path / "metadata.yaml").is_file() or any(path.glob("*.db3")) or any(path.glob("*.mcap"))


def _scan(path: Path, options: SourceOptions) -> ScanRecording:
    camera = {"intrinsics": options.intrinsics, "calibration": options.calibration, "prior": options.prior,
              "up": options.up}
    given = [name for name, value in camera.items() if value is not None]
    if given:
        raise SourceError(path, f"a scan takes no {given[0]} (it is one registered cloud, not camera frames)")
    scale = None if options.depth_scale is None else 1.0 / options.depth_scale
    return ScanRecording(read_cloud(path, scale=scale, depth_correction=options.depth_correction))
