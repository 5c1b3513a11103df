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

from bim2rdt.sources.calibration import correct_points
from bim2rdt.sources.errors import SourceError
from bim2rdt.sources.optional import require

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
        scans = [e57.read_scan(i, colors=True, intensity=True, ignore_missing_fields=True)
                 for i in range(e57.scan_count)]
    except Exception as error:  # libE57Format raises its own exception types
        raise SourceError(path, f"not a readable E57 file ({type(error).__name__}: {_line(error)})") from None
    if not scans:
        raise SourceError(path, "the E57 file holds no scan")
    points = np.concatenate([np.stack([s["cartesianX"], s["cartesianY"], s["cartesianZ"]], axis=1) for s in scans])
    colors = (np.concatenate([np.stack([s["colorRed"], s["colorGreen"], s["colorBlue"]], axis=1) for s in scans])
              if all("colorRed" in s for s in scans) else None)
    intensity = np.concatenate([s["intensity"] for s in scans]) if all("intensity" in s for s in scans) else None
    return points, colors, intensity


def _line(error: Exception) -> str:
    return (str(error).splitlines() or [""])[0][:160]


_READERS = {".pcd": _pcd, ".ply": _ply, ".las": _las, ".laz": _las, ".e57": _e57}
