"""What the report and the BCF need of each frame after verify has let it go: a small copy of its colour image
and its depth, and the intrinsics scaled to them. A VGA frame is ~2.4 MB; its copy ~0.4 MB (depth in float16: ~4 mm
steps at 5 m), and only the first :data:`MAX_VIEWS` are kept, so a long recording's copies stay under 80 MB."""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass, replace

import numpy as np

from bim2rdt.perception import Frame, Intrinsics

THUMB_WIDTH = 320
"""Width (pixels) of a frame's copy; its height keeps the aspect."""
MAX_VIEWS = 200
"""Frames whose copies are kept; later frames are verified and reported without pictures."""


@dataclass(frozen=True)
class FrameView:
    """A frame's small copy: ``rgb`` (h, w, 3) uint8, ``depth`` (h, w) float16 metres (NaN: no return), and the
    ``intrinsics`` of that size (the camera's, scaled)."""

    rgb: np.ndarray
    depth: np.ndarray
    intrinsics: Intrinsics

    @classmethod
    def of(cls, frame: Frame, width: int = THUMB_WIDTH) -> FrameView:
        """The copy of ``frame``, ``width`` pixels wide (nearest pixel: depths are not blended across edges).

        Args:
            frame: An RGB-D frame.
            width: The copy's width, pixels (no wider than the frame).

        Returns:
            The small copy.
        """
        k = frame.intrinsics
        step = max(1, int(round(k.width / width)))
        depth = np.asarray(frame.depth, np.float32)[::step, ::step].astype(np.float16)
        depth[~(depth > 0)] = np.nan
        rgb = np.ascontiguousarray(np.asarray(frame.rgb)[::step, ::step])
        scaled = replace(k, width=rgb.shape[1], height=rgb.shape[0], fx=k.fx / step, fy=k.fy / step,
                         cx=(k.cx + 0.5) / step - 0.5, cy=(k.cy + 0.5) / step - 0.5)
        return cls(rgb, depth, scaled)


class FrameCapture:
    """A frame source passed through unchanged, keeping a :class:`FrameView` of each frame by its index (None for
    a scan); every other attribute (``dropped``, ``warnings``, ``expected_frames``) is the source's."""

    def __init__(self, frames: Iterable, limit: int = MAX_VIEWS) -> None:
        self.frames, self.limit = frames, limit
        self.views: dict[int, FrameView] = {}

    def __iter__(self) -> Iterator:
        self.views = {}
        for index, frame in enumerate(self.frames):
            if isinstance(frame, Frame) and len(self.views) < self.limit:
                self.views[index] = FrameView.of(frame)
            yield frame

    def __getattr__(self, name: str):
        if name == "frames":  # not set yet: no recursion through __getattr__
            raise AttributeError(name)
        return getattr(self.frames, name)
