"""Image files in: colour as RGB uint8, depth as one channel of raw units, with one-line errors naming the file."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from bim2rdt.sources.errors import SourceError


def read_colour(path: Path) -> np.ndarray:
    """(H, W, 3) uint8 RGB from a PNG/JPEG/TIFF (a grey image is repeated to three channels)."""
    image = _read(path, cv2.IMREAD_UNCHANGED)
    if image.dtype != np.uint8:
        raise SourceError(path, f"colour must be 8-bit, got {image.dtype}")
    if image.ndim == 2:
        return np.repeat(image[..., None], 3, axis=2)
    if image.shape[2] == 4:
        return cv2.cvtColor(image, cv2.COLOR_BGRA2RGB)
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)


def read_depth_png(path: Path) -> np.ndarray:
    """(H, W) uint16 raw depth from a 16-bit single-channel PNG; an 8-bit or colour image is refused (it cannot
    hold metric depth)."""
    image = _read(path, cv2.IMREAD_UNCHANGED)
    if image.ndim != 2:
        raise SourceError(path, f"depth must be one channel, got {image.shape[2]} channels")
    if image.dtype != np.uint16:
        raise SourceError(path, f"depth must be a 16-bit image, got {image.dtype}")
    return image


def _read(path: Path, flags: int) -> np.ndarray:
    if not Path(path).is_file():
        raise SourceError(path, "no such image file")
    image = cv2.imread(str(path), flags)
    if image is None:
        raise SourceError(path, "not a readable image")
    return image
