"""PCL ImageGrabber TIFF frames: ``NAME_rgb.tiff`` + ``NAME_depth.tiff`` (+ ``NAME.xml``), read with tifffile.

Depth is uint16 with the .xml's ``depth/z_multiplication_factor`` metres per unit (PCL writes 0.001: millimetres;
0 = no return); the intrinsics are the .xml's ``depth`` focal lengths and principal point. A frame without its own
.xml uses the folder's only .xml (PCL writes one per frame; copies often keep the first). ``time`` comes from the
name ``frame_YYYYMMDDTHHMMSS.ffffff`` (UTC seconds since 1970), else None.
"""

from __future__ import annotations

import xml.etree.ElementTree as ElementTree
from collections.abc import Iterator
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from bim2rdt.perception import Frame, Intrinsics
from bim2rdt.sources.errors import SourceError
from bim2rdt.sources.frames import build_frame, depth_metres, intrinsics_for
from bim2rdt.sources.optional import require
from bim2rdt.sources.options import SourceOptions


def is_grabber_folder(path: Path) -> bool:
    return any(path.glob("*_depth.tif*"))


class GrabberFolder:
    """A :class:`~bim2rdt.sources.FrameSource` over a folder of PCL grabber TIFF frames, in name (time) order."""

    def __init__(self, path: Path, options: SourceOptions) -> None:
        self.path, self.options = Path(path), options
        self.depths = sorted(self.path.glob("*_depth.tif*"))
        if not self.depths:
            raise SourceError(self.path, "no frames: no *_depth.tiff here")
        self.tifffile = require("tifffile", path, "PCL grabber TIFFs")

    def __iter__(self) -> Iterator[Frame]:
        for count, depth_path in enumerate(self.depths):
            if self.options.max_frames is not None and count >= self.options.max_frames:
                return
            yield self._frame(depth_path)

    def _frame(self, depth_path: Path) -> Frame:
        stem = depth_path.name[: depth_path.name.rindex("_depth")]
        raw = self._read(depth_path)
        height, width = raw.shape[:2]
        found, metres_per_unit = self._xml(stem, width, height)
        units_per_metre = self.options.depth_scale or (1.0 / metres_per_unit if metres_per_unit else None)
        if units_per_metre is None:
            raise SourceError(depth_path, "the depth's units are unknown (no .xml z_multiplication_factor): give "
                                          "depth_scale (1000 for millimetres; bim2rdt verify --depth-scale 1000)")
        if raw.dtype.kind == "f" and not self.options.depth_scale and float(np.nanmax(raw, initial=0)) < 20:
            units_per_metre = 1.0  # a float depth TIFF already in metres
        depth = depth_metres(depth_path, raw, units_per_metre)
        intrinsics = intrinsics_for(depth_path, self.options, width, height, found)
        colour_path = next((p for p in depth_path.parent.glob(f"{stem}_rgb.tif*")), None)
        rgb = None if colour_path is None else self._colour(colour_path)
        return build_frame(depth_path, rgb, depth, intrinsics, self.options, time=_time_of(stem),
                           source=depth_path.name)

    def _read(self, path: Path) -> np.ndarray:
        try:
            return self.tifffile.imread(path)
        except Exception as error:  # tifffile raises TiffFileError, ValueError, ... on damaged files
            raise SourceError(path, f"not a readable TIFF ({type(error).__name__})") from None

    def _colour(self, path: Path) -> np.ndarray:
        image = self._read(path)
        if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] < 3:
            raise SourceError(path, f"colour must be 8-bit RGB, got {image.dtype} {image.shape}")
        return np.ascontiguousarray(image[..., :3])

    def _xml(self, stem: str, width: int, height: int) -> tuple[Intrinsics | None, float | None]:
        own = self.path / f"{stem}.xml"
        others = sorted(self.path.glob("*.xml"))
        path = own if own.is_file() else (others[0] if len(others) == 1 else None)
        if path is None:
            return None, None
        try:
            depth = _depth_element(path)
            values = {tag: float(depth.findtext(tag)) for tag in
                      ("focal_length_x", "focal_length_y", "principal_point_x", "principal_point_y")}
            factor = depth.findtext("z_multiplication_factor")
        except (ElementTree.ParseError, AttributeError, TypeError, ValueError) as error:
            raise SourceError(path, f"not a PCL grabber calibration ({type(error).__name__}: {error})") from None
        return (Intrinsics(width, height, values["focal_length_x"], values["focal_length_y"],
                           values["principal_point_x"], values["principal_point_y"]),
                float(factor) if factor is not None else None)


def _depth_element(path: Path):
    """The ``<depth>`` element: PCL writes ``<rgb>`` and ``<depth>`` side by side with no root, so the text is
    wrapped in one before parsing."""
    text = path.read_text()
    body = text.split("?>", 1)[1] if text.lstrip().startswith("<?xml") else text
    return ElementTree.fromstring(f"<grabber>{body}</grabber>").find("depth")


def _time_of(stem: str) -> float | None:
    try:
        stamp = datetime.strptime(stem.removeprefix("frame_"), "%Y%m%dT%H%M%S.%f")
    except ValueError:
        return None
    return stamp.replace(tzinfo=timezone.utc).timestamp()
