"""The seam between recordings and the system: ``open_source(path, **options)`` picks a frame reader from the
path, and every reader is a :class:`FrameSource`, an iterable of checked perception frames.

Readers are found by the file's extension (``FILE_READERS``) or, for a folder, by what it holds
(``FOLDER_READERS``, asked in order). A new format plugs in with one entry: a rosbag reader adds
``".mcap"``, ``".db3"`` and ``".bag"`` to ``FILE_READERS`` with a ``"module:Class"`` whose constructor takes
``(path, options: SourceOptions)``. The reader's module is imported only when a path needs it, so an optional
package (PyAV, ...) is needed only by those who read that format.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Protocol, runtime_checkable

from bim2rdt.perception import Frame
from bim2rdt.sources.errors import SourceError
from bim2rdt.sources.options import parse_options


@runtime_checkable
class FrameSource(Protocol):
    """Frames in the order the sensor took them (each a checked :class:`~bim2rdt.perception.Frame`: depth in
    metres, its intrinsics, ``time``, ``up`` and a prior pose when the recording has them). Iterating again
    starts over. Readers raise :class:`SourceError` in one line for what they cannot read."""

    def __iter__(self) -> Iterator[Frame]: ...


FILE_READERS: dict[str, str] = {
    ".pcd": "bim2rdt.sources.pcd_frame:OrganisedPcd",
    ".mkv": "bim2rdt.sources.azure_kinect:AzureKinectMkv",
    ".mcap": "bim2rdt.sources.rosbag:RosbagSource",
    ".db3": "bim2rdt.sources.rosbag:RosbagSource",
    ".bag": "bim2rdt.sources.rosbag:RosbagSource",
}
"""File extension (lower case) -> ``"module:Class"`` of its reader."""

FOLDER_READERS: list[tuple[str, str]] = [
    ("bim2rdt.sources.recording:is_rosbag_folder", "bim2rdt.sources.rosbag:RosbagSource"),
    ("bim2rdt.sources.tum:is_tum_folder", "bim2rdt.sources.tum:TumFolder"),
    ("bim2rdt.sources.grabber:is_grabber_folder", "bim2rdt.sources.grabber:GrabberFolder"),
    ("bim2rdt.sources.tum:is_pair_folder", "bim2rdt.sources.tum:PairFolder"),
    ("bim2rdt.sources.pcd_folder:is_pcd_folder", "bim2rdt.sources.pcd_folder:PcdFolder"),
]
"""(``"module:function"`` telling whether a folder is in the format, ``"module:Class"`` of its reader), asked in
order."""


def open_source(path: str | Path, **options: object) -> FrameSource:
    """Open the frame reader for a recording (a file or a folder; see the module's note).

    Args:
        path: The recording: a file (.mkv, .bag, .mcap, .db3, ...) or a folder (TUM, colour + depth PNG pairs,
            PCL grabber TIFFs, rosbag2).
        **options: Reader options, as the fields of :class:`~bim2rdt.sources.options.SourceOptions`.

    Returns:
        A :class:`FrameSource`: iterate it for frames (UTC seconds, depth in metres, OpenCV camera axes).

    Raises:
        SourceError: A path that does not exist, a format no reader knows, a bad option, or a recording a
            reader refuses at once (no frames, no intrinsics, ...); frame-level problems surface while
            iterating.
    """
    path = Path(path)
    checked = parse_options(path, options)
    if not path.exists():
        raise SourceError(path, "no such file or folder")
    return _reader(_reader_name(path))(path, checked)


def _reader_name(path: Path) -> str:
    if path.is_dir():
        for looks_like, name in FOLDER_READERS:
            if _reader(looks_like)(path):
                return name
        raise SourceError(path, "no frames here: a folder needs a TUM rgb.txt + depth.txt, a colour + depth PNG pair "
                                "(*_color.png, *_depth.png), PCL grabber TIFFs (*_depth.tiff + .xml), .pcd frames or a "
                                "rosbag2 folder (metadata.yaml)")
    name = FILE_READERS.get(path.suffix.lower())
    if name is None:
        raise SourceError(path, f"no frame reader for '{path.suffix or path.name}' files (readers: "
                                f"{', '.join(sorted(FILE_READERS))}, or a folder)")
    return name


def _reader(name: str) -> Callable:
    module, attribute = name.split(":")
    return getattr(importlib.import_module(module), attribute)
