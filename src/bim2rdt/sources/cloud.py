"""Registered scans in: ``read_cloud(path) -> Cloud`` for ``.pcd`` (pypcd4), ``.ply`` (trimesh), ``.las``/``.laz``
(laspy + lazrs) and ``.e57`` (pye57; every scan in the file, each moved by its pose into the file's frame).

Units are checked where the points enter:

- NaN rows: a row whose x, y and z are all NaN is a no-return (organised clouds keep one per pixel) and is dropped,
  counted in ``Cloud.dropped``; a row with only some coordinates NaN, or any infinite one, is damage and refused.
- Scale: a scan is metres. One whose robust extent (1st to 99th percentile, per axis) exceeds ``MAX_SPAN_M`` is
  refused as looking like millimetres; ``read_cloud(path, scale=0.001)`` converts it, and says so in
  ``Cloud.note``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bim2rdt.sources import budget
from bim2rdt.sources.calibration import correct_points
from bim2rdt.sources.errors import SourceError
from bim2rdt.sources.optional import require

BYTES_PER_POINT = 160
"""What reading a scan allocates per point beyond its stored record (bytes): float64 x, y, z arrays, their
stacked copy, the NaN masks, colours, intensity and the percentile copies of the checks. A reader refuses a scan
whose count times this is over the memory cap (:mod:`bim2rdt.sources.budget`)."""
MAX_SPAN_M = 2000.0
"""The largest robust extent (m) of a scan taken as metres: a building or site scan spans far less than 2 km,
while a 5 m room in millimetres spans 5000."""


@dataclass(frozen=True)
class Cloud:
    """``points`` (N, 3) float64 metres in the scan's registered frame, ``colors`` (N, 3) uint8 or None,
    ``intensity`` (N,) float64 or None (the format's own units), ``path``, ``dropped`` (no-return rows removed) and
    ``note`` (a stated conversion, or "")."""

    points: np.ndarray
    colors: np.ndarray | None
    intensity: np.ndarray | None
    path: Path
    dropped: int = 0
    note: str = ""

    def __len__(self) -> int:
        return len(self.points)


def read_cloud(path: str | Path, scale: float | None = None,
               depth_correction: np.ndarray | list[float] | tuple[float, ...] | None = None) -> Cloud:
    """Read a scan (.pcd .ply .las .laz .e57) as points in metres.

    All-NaN rows (no return) are dropped and counted; a scan whose extent looks like millimetres is refused
    rather than guessed.

    Args:
        path: The scan file.
        scale: Multiplies its coordinates first (0.001 for a scan in millimetres); None keeps them.
        depth_correction: The vector g (1/m) of ``p / (1 - g . p)`` (:mod:`bim2rdt.sources.calibration`),
            applied to the scaled points; meant for a cloud in its camera's frame (an organised RGB-D frame read
            as a scan). Points with no true position are dropped.

    Returns:
        The cloud: (N,3) points in the scan's own frame, metres, with colours and intensity when it has them.

    Raises:
        SourceError: No reader for the suffix, no such file, damaged or empty data, a bad scale or
            correction, or an extent that looks like millimetres; one line naming the file.
    """
    path = Path(path)
    reader = _READERS.get(path.suffix.lower())
    if reader is None:
        raise SourceError(path, f"no scan reader for '{path.suffix or path.name}' files (readers: "
                                f"{', '.join(sorted(_READERS))})")
    if not path.is_file():
        raise SourceError(path, "no such file")
    points, colors, intensity = reader(path)
    cloud = checked_cloud(path, points, colors, intensity, scale)
    return cloud if depth_correction is None else corrected_cloud(cloud, depth_correction)


def corrected_cloud(cloud: Cloud, g) -> Cloud:
    """``cloud`` with the depth correction g applied to its points (camera frame); points with no true position
    (``1 - g . p <= 0``) are dropped and counted in ``dropped``."""
    try:
        points = correct_points(cloud.points, g)
    except ValueError as error:
        raise SourceError(cloud.path, str(error)) from None
    keep = np.isfinite(points).all(axis=1)
    note = "; ".join(filter(None, [cloud.note, f"depth correction g = {np.round(np.asarray(g, float), 6).tolist()}"]))
    return Cloud(points[keep], None if cloud.colors is None else cloud.colors[keep],
                 None if cloud.intensity is None else cloud.intensity[keep], cloud.path,
                 cloud.dropped + int((~keep).sum()), note)


def checked_cloud(path: Path, points, colors, intensity, scale: float | None = None) -> Cloud:
    """A :class:`Cloud` from a reader's arrays, after the NaN and scale rules (see the module's note)."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    all_nan = np.isnan(points).all(axis=1)
    damaged = ~all_nan & ~np.isfinite(points).all(axis=1)
    if damaged.any():
        first = int(np.flatnonzero(damaged)[0])
        raise SourceError(path, f"{int(damaged.sum())} points have a NaN or infinite coordinate beside finite ones "
                                f"(first at row {first}): damaged data, not a no-return")
    keep = ~all_nan
    points = points[keep]
    if not len(points):
        raise SourceError(path, "no points (every row is NaN)" if all_nan.any() else "no points")
    note = ""
    if scale is not None:
        if not np.isfinite(scale) or scale <= 0:
            raise SourceError(path, f"scale must be a positive number, got {scale!r}")
        points = points * float(scale)
        note = f"coordinates multiplied by {scale:g} to metres"
    span = float((np.percentile(points, 99, axis=0) - np.percentile(points, 1, axis=0)).max())
    if span > MAX_SPAN_M:
        raise SourceError(path, f"the scan spans {span:.0f} units: it looks like millimetres (a scan in metres spans "
                                f"under {MAX_SPAN_M:.0f}); read it with scale=0.001 (open_recording: depth_scale=1000; verify --depth-scale 1000)")
    colors = None if colors is None else _colours(np.asarray(colors)[keep])
    intensity = None if intensity is None else np.asarray(intensity, dtype=np.float64).reshape(-1)[keep]
    return Cloud(points, colors, intensity, path, int(all_nan.sum()), note)


def _colours(colors: np.ndarray) -> np.ndarray:
    """(N, >=3) colours as uint8 RGB: 16-bit channels (LAS, some PLY) are scaled down by 257."""
    rgb = colors[:, :3]
    if rgb.dtype == np.uint8:
        return np.ascontiguousarray(rgb)
    if np.issubdtype(rgb.dtype, np.floating) and rgb.size and rgb.max() <= 1.0:
        return np.clip(np.round(rgb * 255), 0, 255).astype(np.uint8)
    if rgb.size and rgb.max() > 255:
        return np.clip(np.round(rgb / 257.0), 0, 255).astype(np.uint8)
    return np.clip(rgb, 0, 255).astype(np.uint8)


def _pcd(path: Path):
    from bim2rdt.sources.pcd_frame import packed_rgb, read_pcd

    data = read_pcd(path).pc_data
    names = data.dtype.names
    missing = [name for name in ("x", "y", "z") if name not in names]
    if missing:
        raise SourceError(path, f"the PCD has no field {missing[0]!r} (fields: {', '.join(names)})")
    points = np.stack([data[name].astype(np.float64) for name in ("x", "y", "z")], axis=1)
    intensity = data["intensity"] if "intensity" in names else None
    return points, packed_rgb(data), intensity


def _ply(path: Path):
    import trimesh

    check_ply_header(path)
    try:
        loaded = trimesh.load(path, process=False)
    except Exception as error:  # trimesh raises many kinds on a damaged file
        raise SourceError(path, f"not a readable PLY ({type(error).__name__}: {_line(error)})") from None
    if isinstance(loaded, trimesh.Scene):
        raise SourceError(path, "the PLY holds a scene of several geometries, not one scan")
    points = np.asarray(loaded.vertices)
    colors = _ply_colours(loaded, len(points))
    vertex = loaded.metadata.get("_ply_raw", {}).get("vertex", {}).get("data")
    intensity = None
    if vertex is not None and vertex.dtype.names and "intensity" in vertex.dtype.names:
        intensity = np.asarray(vertex["intensity"]).reshape(-1)
    return points, colors, intensity


PLY_TYPE_BYTES = {"char": 1, "int8": 1, "uchar": 1, "uint8": 1, "short": 2, "int16": 2, "ushort": 2, "uint16": 2,
                  "int": 4, "int32": 4, "uint": 4, "uint32": 4, "float": 4, "float32": 4, "double": 8, "float64": 8}
"""Bytes of each PLY property type."""
MAX_PLY_HEADER_BYTES = 64 * 1024
"""A PLY header ends within this many bytes, at its ``end_header`` line."""


def check_ply_header(path: Path) -> None:
    """Check a PLY header's element counts against the file's size and the memory cap before trimesh reads it:
    binary rows take their properties' bytes (a list at least its count's), ASCII rows 2 bytes a property
    (an ASCII PLY declaring 2e9 vertices gave a traceback).

    Args:
        path: The .ply file.

    Raises:
        SourceError: One line naming what the header declares and what the file holds.
    """
    size = path.stat().st_size
    with path.open("rb") as file:
        text = file.read(MAX_PLY_HEADER_BYTES)
    end = text.find(b"end_header")
    if not text.startswith(b"ply") or end < 0:
        raise SourceError(path, f"not a PLY file (no 'ply' ... 'end_header' in its first "
                                f"{MAX_PLY_HEADER_BYTES // 1024} kB)")
    elements: list[list] = []  # [name, count, least bytes a row, properties]
    ascii_format = True
    for words in (line.split() for line in text[:end].decode("ascii", "replace").splitlines()):
        try:
            if words[:1] == ["format"]:
                ascii_format = words[1] == "ascii"
            elif words[:1] == ["element"]:
                elements.append([words[1], int(words[2]), 0, 0])
            elif words[:1] == ["property"] and elements:
                kind = words[2] if words[1] == "list" else words[1]
                elements[-1][2] += PLY_TYPE_BYTES[kind]
                elements[-1][3] += 1
        except (IndexError, KeyError, ValueError):
            raise SourceError(path, f"a damaged PLY header line: {' '.join(words)[:60]!r}") from None
    if any(count < 0 for _, count, _, _ in elements):
        raise SourceError(path, "a damaged PLY header: a negative element count")
    least = sum(count * (2 * properties if ascii_format else row) for _, count, row, properties in elements)
    what = ", ".join(f"{count:.3g} {name}" for name, count, _, _ in elements) + (" as text" if ascii_format else "")
    budget.check_claim(path, end + len("end_header") + least, what, size)
    budget.check_memory(path, sum(count * (row + BYTES_PER_POINT) for _, count, row, _ in elements), what)


def _ply_colours(loaded, count: int) -> np.ndarray | None:
    import trimesh

    if isinstance(loaded, trimesh.PointCloud):
        colors = np.asarray(loaded.colors)
        return colors if colors.shape[:1] == (count,) and colors.size else None
    visual = getattr(loaded, "visual", None)
    if visual is not None and visual.kind == "vertex":
        return np.asarray(visual.vertex_colors)
    return None


def _las(path: Path):
    laspy = require("laspy", path, "a .las/.laz scan")
    check_las_header(path)
    try:
        las = laspy.read(path)
    except laspy.errors.LaspyException as error:
        message = _line(error)
        if "lazrs" in message or "backend" in message.lower():
            raise SourceError(path, "reading .laz needs the Python package 'lazrs': pip install 'bim2rdt[sensors]'") \
                from None
        raise SourceError(path, f"not a readable LAS/LAZ file ({message})") from None
    except (OSError, ValueError) as error:
        raise SourceError(path, f"not a readable LAS/LAZ file ({_line(error)})") from None
    points = np.stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)], axis=1)
    names = set(las.point_format.dimension_names)
    colors = np.stack([las.red, las.green, las.blue], axis=1) if {"red", "green", "blue"} <= names else None
    intensity = np.asarray(las.intensity) if "intensity" in names else None
    return points, colors, intensity


def _e57(path: Path):
    pye57 = require("pye57", path, "an .e57 scan")
    try:
        e57 = pye57.E57(str(path))
        counts = [int(e57.get_header(i).point_count) for i in range(e57.scan_count)]
        budget.check_memory(path, sum(counts) * E57_BYTES_PER_POINT, f"{sum(counts):.3g} points in "
                                                                       f"{len(counts)} scans")
        scans = [e57.read_scan(i, colors=True, intensity=True, ignore_missing_fields=True)
                 for i in range(e57.scan_count)]
    except SourceError:
        raise
    except Exception as error:  # libE57Format raises its own exception types
        raise SourceError(path, f"not a readable E57 file ({type(error).__name__}: {_line(error)})") from None
    if not scans:
        raise SourceError(path, "the E57 file holds no scan")
    points = np.concatenate([np.stack([s["cartesianX"], s["cartesianY"], s["cartesianZ"]], axis=1) for s in scans])
    colors = (np.concatenate([np.stack([s["colorRed"], s["colorGreen"], s["colorBlue"]], axis=1) for s in scans])
              if all("colorRed" in s for s in scans) else None)
    intensity = np.concatenate([s["intensity"] for s in scans]) if all("intensity" in s for s in scans) else None
    return points, colors, intensity


E57_BYTES_PER_POINT = 8 * 7 + BYTES_PER_POINT
"""What reading an E57 scan allocates per point (bytes): pye57's float64 x, y, z, intensity and colour buffers,
then the checks'. Its points are bit-packed and compressed, so the file's size bounds nothing: the cap does."""
LAS_VLR_HEADER, LAS_EVLR_HEADER = 54, 60
"""Bytes of a LAS variable-length record's header, and of an extended one's (LAS 1.4, ASPRS R15)."""
LAS_MIN_HEADER = {0: 227, 1: 227, 2: 227, 3: 235, 4: 375}
"""The public header block's size (bytes) by LAS 1.minor."""


def check_las_header(path: Path) -> None:
    """Check a LAS/LAZ header against the file's size before laspy reads it (a 227-byte file declaring 2^32
    VLRs hung laspy with memory growing; a 267-byte one declaring 3e8 points took 6 GB).

    The VLRs are walked by their lengths (at most the file's size / 54 steps) and must end where the points
    begin; uncompressed points (count x record length) must be in the file; compressed ones (LAZ) and every
    scan must fit the memory cap.

    Args:
        path: The .las or .laz file.

    Raises:
        SourceError: One line naming what the header claims and what the file holds.
    """
    import struct

    size = path.stat().st_size
    with path.open("rb") as file:
        head = file.read(375)
        if len(head) < 227 or head[:4] != b"LASF":
            raise SourceError(path, f"not a LAS/LAZ file (no LASF header of 227 bytes; the file has {size})")
        major, minor = head[24], head[25]
        header_size, offset, vlrs, point_format, record_length, legacy_count = struct.unpack_from("<HIIBHI", head, 94)
        if major != 1 or minor not in LAS_MIN_HEADER:
            raise SourceError(path, f"not a LAS/LAZ file: version {major}.{minor} (LAS 1.0 to 1.4 are read)")
        if not LAS_MIN_HEADER[minor] <= header_size <= offset <= size:
            raise SourceError(path, f"a damaged LAS header: header {header_size} bytes, points from byte {offset}, "
                                    f"file {size} bytes")
        file.seek(header_size)
        _check_vlrs(path, file.read(offset - header_size), vlrs)
    count = legacy_count
    if minor >= 4 and len(head) >= 255:
        evlr_start, evlrs, count64 = struct.unpack_from("<QIQ", head, 235)
        count = max(count, count64)
        if evlrs and evlr_start + evlrs * LAS_EVLR_HEADER > size:
            budget.check_claim(path, evlr_start + evlrs * LAS_EVLR_HEADER, f"{evlrs} extended VLRs", size)
    if record_length == 0 and count:
        raise SourceError(path, "a damaged LAS header: points of 0 bytes")
    what = f"{count:.3g} points of {record_length} bytes"
    if not point_format & 0x80:  # uncompressed: the points are in the file as they are
        budget.check_claim(path, offset + count * record_length, what, size)
    budget.check_memory(path, count * (record_length + BYTES_PER_POINT), what)


def _check_vlrs(path: Path, block: bytes, declared: int) -> None:
    """Walk ``declared`` VLR headers through ``block`` (the bytes between the header and the points)."""
    import struct

    at = 0
    for index in range(declared):
        if at + LAS_VLR_HEADER > len(block):
            raise SourceError(path, f"its header declares {declared} VLRs but only {index} fit before the points "
                                    f"(byte {len(block)} after the header)")
        at += LAS_VLR_HEADER + struct.unpack_from("<H", block, at + 52)[0]
    if at > len(block):
        raise SourceError(path, "a damaged LAS file: its last VLR runs into the points")


def _line(error: Exception) -> str:
    return (str(error).splitlines() or [""])[0][:160]


_READERS = {".pcd": _pcd, ".ply": _ply, ".las": _las, ".laz": _las, ".e57": _e57}
