"""A folder of ``.pcd`` files as one recording, in name order: each organised file is a camera frame (as
:class:`~bim2rdt.sources.pcd_frame.OrganisedPcd` reads it, with the folder's options), each unorganised one a
scan (a :class:`~bim2rdt.sources.Cloud`, depth correction applied). ``time`` comes from a name
``frame_YYYYMMDDTHHMMSS.ffffff`` (as PCL's grabbers write them), else None.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

from bim2rdt.sources.errors import SourceError
from bim2rdt.sources.options import SourceOptions


def is_pcd_folder(path: Path) -> bool:
    """Whether the folder holds ``.pcd`` files (any case)."""
    return any(p.suffix.lower() == ".pcd" for p in path.iterdir() if p.is_file())


class PcdFolder:
    """A :class:`~bim2rdt.sources.FrameSource` over a folder's ``.pcd`` files, sorted by name."""

    def __init__(self, path: Path, options: SourceOptions) -> None:
        self.path, self.options = Path(path), options
        self.files = sorted(p for p in self.path.iterdir() if p.is_file() and p.suffix.lower() == ".pcd")
        if not self.files:
            raise SourceError(self.path, "no frames: no .pcd file here")

    @property
    def expected_frames(self) -> int:
        """How many files the folder holds (one frame or scan each)."""
        return len(self.files)

    def __iter__(self) -> Iterator:
        from bim2rdt.sources.grabber import _time_of
        from bim2rdt.sources.pcd_frame import OrganisedPcd

        for count, path in enumerate(self.files):
            if self.options.max_frames is not None and count >= self.options.max_frames:
                return
            try:
                [frame] = list(OrganisedPcd(path, self.options))
            except SourceError as error:
                if "not organised" not in str(error):
                    raise
                yield self._scan(path)
                continue
            yield replace(frame, time=_time_of(path.stem)) if frame.time is None else frame

    def _scan(self, path: Path):
        from bim2rdt.sources.calibration import correct_points
        from bim2rdt.sources.cloud import read_cloud

        cloud = read_cloud(path)
        if self.options.depth_correction is not None:
            cloud = replace(cloud, points=correct_points(cloud.points, self.options.depth_correction))
        return cloud


def write_organised_pcd(frame, path: Path) -> Path:
    """Write a frame as an organised binary ``.pcd`` (x y z rgb on its image grid, NaN where no return), as PCL
    writes a Kinect frame: the format :class:`PcdFolder` reads back.

    Args:
        frame: A :class:`~bim2rdt.perception.Frame` (depth in metres, its intrinsics and colour).
        path: The file to write.

    Returns:
        ``path``.
    """
    import numpy as np

    from bim2rdt.atomic import write_bytes_atomic

    k = frame.intrinsics
    v, u = np.mgrid[0:k.height, 0:k.width]
    z = np.where(frame.valid_depth, frame.depth, np.nan).astype(np.float64)
    xyz = np.stack([(u - k.cx) / k.fx * z, (v - k.cy) / k.fy * z, z], axis=-1).reshape(-1, 3)
    rgb = frame.rgb.reshape(-1, 3).astype(np.uint32)
    packed = (rgb[:, 0] << 16) | (rgb[:, 1] << 8) | rgb[:, 2]
    header = ("# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\n"
              f"TYPE F F F U\nCOUNT 1 1 1 1\nWIDTH {k.width}\nHEIGHT {k.height}\nVIEWPOINT 0 0 0 1 0 0 0\n"
              f"POINTS {k.width * k.height}\nDATA binary\n")
    body = np.empty(len(xyz), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("rgb", "<u4")])
    body["x"], body["y"], body["z"], body["rgb"] = xyz[:, 0], xyz[:, 1], xyz[:, 2], packed
    return write_bytes_atomic(Path(path), header.encode() + body.tobytes())
