"""An organised ``.pcd`` frame (PCL / Kinect): x, y, z (+ rgb) on the image grid, read with pypcd4.

Depth is z per pixel; NaN points are no return. The intrinsics are fitted from the cloud itself (u = fx x/z + cx
and v = fy y/z + cy, least squares over the valid pixels) unless given; a cloud that is not a pinhole image
(residual over half a pixel) is refused. Colour is the packed ``rgb``/``rgba`` field (0x00RRGGBB), if any.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np

from bim2rdt.perception import Frame, Intrinsics
from bim2rdt.sources.errors import SourceError
from bim2rdt.sources.frames import build_frame, depth_metres, intrinsics_for
from bim2rdt.sources.options import SourceOptions

MAX_FIT_RESIDUAL_PX = 0.5
"""A fitted pinhole's largest pixel residual; above it the cloud is not one camera's image."""


NOT_ORGANISED = ("the PCD is not organised: it is a scan, not a camera frame; open_recording (bim2rdt verify) "
                 "reads it as one, or read_cloud")
"""Why an unorganised PCD is no frame, and what reads it."""


class OrganisedPcd:
    """A :class:`~bim2rdt.sources.FrameSource` of one organised PCD frame."""

    def __init__(self, path: Path, options: SourceOptions) -> None:
        from bim2rdt.sources.optional import require

        self.path, self.options = Path(path), options
        if not pcd_is_organised(self.path):
            raise SourceError(self.path, NOT_ORGANISED)
        require("pypcd4", self.path, "a .pcd file")  # imported with the source (~20 ms once), not in its frame

    def __iter__(self) -> Iterator[Frame]:
        xyz, rgb = read_organised(self.path)
        height, width = xyz.shape[:2]
        depth = depth_metres(self.path, xyz[..., 2], self.options.depth_scale or 1.0)
        found = None if self.options.intrinsics is not None else fit_intrinsics(self.path, xyz)
        intrinsics = intrinsics_for(self.path, self.options, width, height, found)
        yield build_frame(self.path, rgb, depth, intrinsics, self.options, source=self.path.name)


def pcd_is_organised(path: Path) -> bool:
    """True when the PCD's header gives a ``HEIGHT`` above 1 (a camera image's grid); False for a scan (height 1).
    A header that does not say is taken as organised: the frame reader then names what is wrong.

    Args:
        path: A ``.pcd`` file.

    Returns:
        Whether it is an organised (image-grid) cloud.
    """
    try:
        with open(path, "rb") as handle:
            head = handle.read(4096)
    except OSError as error:
        raise SourceError(path, f"cannot read: {error.strerror or error}") from None
    for line in head.split(b"\n"):
        words = line.split()
        if len(words) == 2 and words[0].upper() == b"HEIGHT":
            return not words[1].isdigit() or int(words[1]) > 1
        if words and words[0].upper() == b"DATA":
            break
    return True


def read_pcd(path: Path):
    """The file's pypcd4 ``PointCloud``, or :class:`SourceError` in one line; its header's counts are checked
    against the file's size and the memory cap first (:func:`check_pcd_header`)."""
    from bim2rdt.sources.optional import require

    pypcd4 = require("pypcd4", path, "a .pcd file")
    check_pcd_header(path)
    try:
        return pypcd4.PointCloud.from_path(path)
    except Exception as error:  # pypcd4 raises bare exceptions of many kinds on a damaged file
        raise SourceError(path, f"not a readable PCD file ({type(error).__name__}: {_line(error)})") from None


def read_organised(path: Path) -> tuple[np.ndarray, np.ndarray | None]:
    """(H, W, 3) float64 camera-frame points (NaN = no return) and (H, W, 3) uint8 colour or None."""
    cloud = read_pcd(path)
    data, meta = cloud.pc_data, cloud.metadata
    missing = [name for name in ("x", "y", "z") if name not in data.dtype.names]
    if missing:
        raise SourceError(path, f"the PCD has no field {missing[0]!r} (fields: {', '.join(data.dtype.names)})")
    if meta.height <= 1:
        raise SourceError(path, f"{NOT_ORGANISED} (height {meta.height}, width {meta.width})")
    shape = (meta.height, meta.width)
    xyz = np.empty((len(data), 3))
    for axis, name in enumerate(("x", "y", "z")):
        xyz[:, axis] = data[name]  # float32 -> float64 in place, exact
    xyz[~_finite_rows(xyz)] = np.nan
    return xyz.reshape(*shape, 3), packed_rgb(data, shape)


def _finite_rows(points: np.ndarray) -> np.ndarray:
    """(N,) whether every coordinate of each of ``points`` (N, 3) is finite (a column at a time: no (N, 3) mask)."""
    return np.isfinite(points[:, 0]) & np.isfinite(points[:, 1]) & np.isfinite(points[:, 2])


MAX_PCD_HEADER_BYTES = 64 * 1024
"""A PCD header (about ten short lines) ends within this many bytes, at its DATA line."""
LZF_MAX_RATIO = 100
"""LZF (a binary_compressed PCD) turns at most ~88 bytes into 1 (a 264-byte back-reference in 3 bytes): a file
declaring more than this times its size is damaged."""
PCD_BYTES_PER_POINT = 160
"""What reading a PCD allocates per point beyond its record (bytes): pypcd4's record array, float64 x, y, z, the
organised grid, masks and the colour."""


def check_pcd_header(path: Path) -> None:
    """Check a PCD header's counts (WIDTH x HEIGHT, POINTS, SIZE x COUNT) against the file's size and the memory
    cap before pypcd4 reads it: binary data must be in the file, ASCII needs 2 bytes a value at least, LZF data
    at most :data:`LZF_MAX_RATIO` times the file (an ASCII PCD declaring 100000 x 100000 gave a traceback).

    Args:
        path: The .pcd file.

    Raises:
        SourceError: One line naming what the header declares and what the file holds.
    """
    from bim2rdt.sources import budget

    size = path.stat().st_size
    with path.open("rb") as file:
        text = file.read(MAX_PCD_HEADER_BYTES)
    fields, end, at = {}, None, 0
    for line in text.split(b"\n"):
        at += len(line) + 1
        words = line.decode("ascii", "replace").split()
        if words and not words[0].startswith("#"):
            fields[words[0].upper()] = words[1:]
        if words and words[0].upper() == "DATA":
            end = at
            break
    if end is None:
        raise SourceError(path, f"not a PCD file (no DATA line in its first {MAX_PCD_HEADER_BYTES // 1024} kB)")
    try:
        sizes = [int(v) for v in fields.get("SIZE", [])]
        counts = [int(v) for v in fields.get("COUNT", ["1"] * len(sizes))]
        width, height = int(fields["WIDTH"][0]), int(fields.get("HEIGHT", ["1"])[0])
        points = int(fields.get("POINTS", [width * height])[0])
    except (KeyError, ValueError, IndexError):
        raise SourceError(path, "a damaged PCD header (WIDTH, HEIGHT, POINTS, SIZE or COUNT is not a number)") \
            from None
    if min([width, height, points, *sizes, *counts], default=0) < 0 or len(counts) != len(sizes):
        raise SourceError(path, "a damaged PCD header (negative counts, or SIZE and COUNT of different lengths)")
    count = max(points, width * height)
    record = sum(s * c for s, c in zip(sizes, counts))
    kind = (fields["DATA"] or ["?"])[0].lower()
    what = f"{width} x {height} points ({count:.3g}) of {record} bytes"
    data = size - end
    if kind == "binary":
        budget.check_claim(path, end + count * record, what, size)
    elif kind == "ascii":
        budget.check_claim(path, end + count * max(1, sum(counts)) * 2 - 1, f"{what} as text", size)
    elif kind == "binary_compressed" and count * record > LZF_MAX_RATIO * max(data, 0):
        budget.check_claim(path, end + count * record / LZF_MAX_RATIO, f"{what}, compressed", size)
    budget.check_memory(path, count * (record + PCD_BYTES_PER_POINT), what)


def packed_rgb(data: np.ndarray, shape: tuple[int, int] | None = None) -> np.ndarray | None:
    """The PCL packed colour field (``rgb`` or ``rgba``: 0x00RRGGBB in 4 bytes, often typed float) as uint8
    (N, 3), reshaped to ``shape`` + (3,) if given; None without one."""
    name = next((n for n in ("rgb", "rgba") if n in data.dtype.names), None)
    if name is None or data.dtype[name].itemsize != 4:
        return None
    packed = np.ascontiguousarray(data[name]).view(np.uint32)
    rgb = np.stack([(packed >> 16) & 255, (packed >> 8) & 255, packed & 255], axis=-1).astype(np.uint8)
    return rgb.reshape(*shape, 3) if shape is not None else rgb


def fit_intrinsics(path, xyz: np.ndarray) -> Intrinsics:
    """The pinhole that projects the organised cloud's points onto their own pixels (least squares)."""
    height, width = xyz.shape[:2]
    flat = xyz.reshape(-1, 3)
    index = np.flatnonzero(_finite_rows(flat) & (flat[:, 2] > 0))  # row-major: pixel (v, u) = divmod
    if len(index) < 100:
        raise SourceError(path, f"only {len(index)} valid points: too few to fit the camera's intrinsics; "
                                "give them (intrinsics=...; bim2rdt verify --intrinsics FILE.json)")
    valid = flat[index]
    v, u = np.divmod(index, width)
    fx, cx, ru = _line_fit(valid[:, 0] / valid[:, 2], u)
    fy, cy, rv = _line_fit(valid[:, 1] / valid[:, 2], v)
    if max(ru, rv) > MAX_FIT_RESIDUAL_PX or fx <= 0 or fy <= 0:
        raise SourceError(path, f"the organised cloud is not a pinhole image (fit residual {max(ru, rv):.2f} px); "
                                "give the intrinsics (intrinsics=...; bim2rdt verify --intrinsics FILE.json)")
    return Intrinsics(width, height, *(round(float(k), 4) for k in (fx, fy, cx, cy)))


def _line_fit(slope_x: np.ndarray, pixel: np.ndarray) -> tuple[float, float, float]:
    """pixel = f * slope_x + c by least squares, in closed form about the means (a 2-parameter line: no SVD of an
    (N, 2) matrix, 15x faster on a VGA frame; the same f and c as ``lstsq`` to ~1e-12 px, well under the 1e-4 the
    intrinsics keep): (f, c, largest residual in pixels)."""
    pixel = pixel.astype(np.float64)
    slope_mean, pixel_mean = float(slope_x.mean()), float(pixel.mean())
    centred = slope_x - slope_mean
    spread = float(np.sum(centred * centred))  # numpy's sums, not BLAS's dot (no threads woken for 250,000 terms)
    f = float(np.sum(centred * (pixel - pixel_mean))) / spread if spread > 0 else 0.0
    c = pixel_mean - f * slope_mean
    return f, c, float(np.abs(f * slope_x + c - pixel).max())


def _line(error: Exception) -> str:
    return (str(error).splitlines() or [""])[0][:160]
