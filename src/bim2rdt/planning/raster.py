"""Footprints: the cells one thing occupies in the robot's height band, rasterised from its mesh or shape.

The plan-view footprint of a solid inside the band ``z_lo <= z <= z_hi`` is exactly the union of
- each surface triangle clipped to the band, projected to the floor (a convex polygon; a vertical face projects
  to a line), and
- the solid's cross-sections at ``z_lo`` and ``z_hi``, filled (so a wall whose faces all straddle the band
  comes out solid, not as an outline; see ``_loop_fill`` for the rule).
So a table top at 0.75 m, a wall, a sloping roof that comes down into the band, and a beam lying on the slab all
come out right, with no sampling of heights. Polygons are filled by OpenCV with 1/16-cell sub-pixel precision.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from bim2rdt.planning.frame import GridFrame

_SUBPIXEL_BITS = 4
_ON_PLANE_NUDGE = 1e-9


@dataclass(frozen=True, eq=False)
class Footprint:
    """The cells one source occupies: ``mask`` (h, w) bool whose first cell is grid cell (``row0``, ``col0``).

    ``kind`` says what the source is: ``element`` (a BIM element), ``door`` (a door closed by the policy),
    ``floor edge`` (where the storey has no floor), ``object`` (observed on site), ``zone`` (a keep-out zone),
    ``person`` (a worker's keep-out circle)."""

    name: str
    kind: str
    row0: int
    col0: int
    mask: np.ndarray
    global_id: str | None = None
    ifc_class: str | None = None

    @property
    def window(self) -> tuple[slice, slice]:
        """The grid slice the mask covers."""
        return slice(self.row0, self.row0 + self.mask.shape[0]), slice(self.col0, self.col0 + self.mask.shape[1])

    @property
    def label(self) -> str:
        """How error messages and reports name it: 'Door D01 (IfcDoor)', 'Exclusion Zone (keep-out zone)'."""
        what = {"zone": "keep-out zone", "person": "worker", "object": "observed object",
                "floor edge": "no floor beyond"}.get(self.kind, self.ifc_class or self.kind)
        return f"{self.name} ({what})"

    def placed(self, frame: GridFrame) -> Footprint | None:
        """This footprint cut to a grid.

        Args:
            frame: The grid's frame.

        Returns:
            The part inside the grid, or None if nothing of it is inside or it is empty.
        """
        rows, cols = frame.shape
        r0, c0 = max(self.row0, 0), max(self.col0, 0)
        r1, c1 = min(self.row0 + self.mask.shape[0], rows), min(self.col0 + self.mask.shape[1], cols)
        if r1 <= r0 or c1 <= c0:
            return None
        mask = self.mask[r0 - self.row0:r1 - self.row0, c0 - self.col0:c1 - self.col0]
        if not mask.any():
            return None
        return Footprint(self.name, self.kind, r0, c0, np.ascontiguousarray(mask), self.global_id, self.ifc_class)


def mesh_cells(vertices: np.ndarray, faces: np.ndarray, z_band: tuple[float, float],
               frame: GridFrame) -> tuple[int, int, np.ndarray] | None:
    """(row0, col0, mask) of the part of a mesh (world metres) inside the world heights ``z_band``, or None when
    no part of it is inside the band (or the grid)."""
    triangles = np.asarray(vertices, float)[np.asarray(faces, int)].reshape(-1, 3, 3)
    z_lo, z_hi = z_band
    z = triangles[..., 2]
    triangles = triangles[(z.max(axis=1) >= z_lo) & (z.min(axis=1) <= z_hi)]
    if len(triangles) == 0:
        return None
    points, valid = _clipped_polygons(triangles, z_lo, z_hi)
    polygons = frame.to_cells(points)
    window = _window(polygons[valid], frame)
    if window is None:
        return None
    row0, col0, shape = window
    polygons -= (col0, row0)
    mask = _fill_convex(polygons, valid, shape)
    for plane in (z_lo, z_hi):
        section = _section_segments(triangles, plane)
        if len(section):
            filled = _loop_fill(frame.to_cells(section) - (col0, row0), shape)
            if filled is not None:
                mask |= filled
    return (row0, col0, mask) if mask.any() else None


def polygon_cells(polygon_xy: np.ndarray, frame: GridFrame) -> tuple[int, int, np.ndarray] | None:
    """(row0, col0, mask) of a simple polygon (N, 2) world metres; None outside the grid."""
    polygon = frame.to_cells(np.asarray(polygon_xy, float).reshape(-1, 2))
    window = _window(polygon, frame)
    if window is None:
        return None
    row0, col0, shape = window
    mask = np.zeros(shape, np.uint8)
    cv2.fillPoly(mask, [_fixed(polygon - (col0, row0))], 1, lineType=cv2.LINE_8, shift=_SUBPIXEL_BITS)
    return (row0, col0, mask.astype(bool)) if mask.any() else None


def disc_cells(centre_xy, radius: float, frame: GridFrame) -> tuple[int, int, np.ndarray] | None:
    """(row0, col0, mask) of the cells whose centres lie within ``radius`` metres of ``centre_xy``."""
    centre = np.asarray(centre_xy, float)
    window = _window(frame.to_cells(np.array([centre - radius, centre + radius])), frame)
    if window is None:
        return None
    row0, col0, (h, w) = window
    rows, cols = np.mgrid[row0:row0 + h, col0:col0 + w]
    mask = np.linalg.norm(frame.centres(rows, cols) - centre, axis=-1) <= radius
    return (row0, col0, mask) if mask.any() else None


def fill_triangles(triangles_xy: np.ndarray, frame: GridFrame) -> np.ndarray:
    """A whole-grid bool mask of the union of triangles (M, 3, 2) world metres (each filled on its own)."""
    polygons = frame.to_cells(np.asarray(triangles_xy, float).reshape(-1, 3, 2))
    return _fill_convex(polygons, np.ones(polygons.shape[:2], bool), frame.shape)


def _clipped_polygons(triangles: np.ndarray, z_lo: float, z_hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Each triangle clipped to the band as a convex polygon in plan: (M, 9, 2) points in boundary order and
    (M, 9) validity. The clipped polygon's corners are the triangle's corners inside the band and its edges'
    crossings of the two planes; sorting them by angle about their centroid orders them (the polygon is convex)."""
    z = triangles[..., 2]
    corners_in = (z >= z_lo) & (z <= z_hi)
    starts, ends = triangles, np.roll(triangles, -1, axis=1)
    crossings, crossing_ok = [], []
    for plane in (z_lo, z_hi):
        dz = ends[..., 2] - starts[..., 2]
        t = (plane - starts[..., 2]) / np.where(dz == 0, 1.0, dz)
        ok = (dz != 0) & (t > 0) & (t < 1)
        crossing_ok.append(ok)
        crossings.append(starts[..., :2] + np.where(ok, t, 0.0)[..., None] * (ends[..., :2] - starts[..., :2]))
    points = np.concatenate([triangles[..., :2], *crossings], axis=1)
    valid = np.concatenate([corners_in, *crossing_ok], axis=1)
    centroid = (points * valid[..., None]).sum(axis=1) / np.maximum(valid.sum(axis=1), 1)[:, None]
    angle = np.arctan2(points[..., 1] - centroid[:, None, 1], points[..., 0] - centroid[:, None, 0])
    order = np.argsort(np.where(valid, angle, np.inf), axis=1)
    points = np.take_along_axis(points, order[..., None], axis=1)
    valid = np.take_along_axis(valid, order, axis=1)
    return points, valid


def _fill_convex(polygons: np.ndarray, valid: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Fill each convex polygon (M, K, 2) cell coordinates (invalid points repeat the first valid one)."""
    mask = np.zeros(shape, np.uint8)
    keep = valid.any(axis=1)
    polygons, valid = polygons[keep], valid[keep]
    polygons = np.where(valid[..., None], polygons, polygons[:, :1])
    for polygon in _fixed(polygons):
        cv2.fillConvexPoly(mask, polygon, 1, lineType=cv2.LINE_8, shift=_SUBPIXEL_BITS)
    return mask.astype(bool)


def _section_segments(triangles: np.ndarray, plane: float) -> np.ndarray:
    """The cross-section of a triangle mesh with the plane z = ``plane``: (S, 2, 2) plan segments, each running
    along ``normal x up`` of its triangle, so the loops of an outward-facing closed mesh all turn the same way."""
    dz = triangles[..., 2] - plane
    dz = np.where(dz == 0.0, _ON_PLANE_NUDGE, dz)
    above = dz > 0
    crosses = above != np.roll(above, -1, axis=1)
    keep = crosses.sum(axis=1) == 2
    if not keep.any():
        return np.zeros((0, 2, 2))
    starts, dz_start, crosses = triangles[keep], dz[keep], crosses[keep]
    ends, dz_end = np.roll(starts, -1, axis=1), np.roll(dz_start, -1, axis=1)
    t = dz_start / np.where(crosses, dz_start - dz_end, 1.0)
    points = starts[..., :2] + t[..., None] * (ends[..., :2] - starts[..., :2])
    segments = points[crosses].reshape(-1, 2, 2)
    normals = np.cross(starts[:, 1] - starts[:, 0], starts[:, 2] - starts[:, 0])
    along = (segments[:, 1] - segments[:, 0]) @ np.array([[0.0, -1.0], [1.0, 0.0]]).T  # rotate by +90 degrees
    backwards = np.einsum("ij,ij->i", along, normals[:, :2]) < 0  # i.e. direction . (n_y, -n_x) < 0
    segments[backwards] = segments[backwards, ::-1]
    return segments


def _loop_fill(segments: np.ndarray, shape: tuple[int, int]) -> np.ndarray | None:
    """Scanline fill of closed loops given as directed segments (S, 2, 2) in cell coordinates. A cell is inside
    when a ray from its centre crosses the loops an odd number of times (even-odd) or with a non-zero winding
    number (nonzero rule: overlapping parts of one mesh, which even-odd would hollow out). The winding number
    is used only when every row's crossings cancel (consistently oriented faces). None if a row has an odd
    number of crossings: the section is not closed (an open surface mesh), so no fill is guessed."""
    h, w = shape
    (u0, v0), (u1, v1) = segments[:, 0].T, segments[:, 1].T
    sloped = v0 != v1
    u0, v0, u1, v1 = u0[sloped], v0[sloped], u1[sloped], v1[sloped]
    first = np.clip(np.ceil(np.minimum(v0, v1) - 0.5), 0, h).astype(int)
    last = np.clip(np.ceil(np.maximum(v0, v1) - 0.5), 0, h).astype(int)
    counts = last - first
    which = np.repeat(np.arange(len(counts)), counts)
    rows = first[which] + np.arange(len(which)) - np.repeat(np.cumsum(counts) - counts, counts)
    u = u0[which] + (rows + 0.5 - v0[which]) * (u1[which] - u0[which]) / (v1[which] - v0[which])
    cols = np.clip(np.ceil(u - 0.5), 0, w).astype(int)
    crossings, winding = np.zeros((h, w + 1), np.int32), np.zeros((h, w + 1), np.int32)
    np.add.at(crossings, (rows, cols), 1)
    np.add.at(winding, (rows, cols), np.where(v1[which] > v0[which], 1, -1))
    if np.any(crossings.sum(axis=1) % 2):
        return None
    inside = np.cumsum(crossings, axis=1)[:, :w] % 2 == 1
    if not np.any(winding.sum(axis=1)):
        inside |= np.cumsum(winding, axis=1)[:, :w] != 0
    return inside


def _window(points_uv: np.ndarray, frame: GridFrame) -> tuple[int, int, tuple[int, int]] | None:
    """(row0, col0, (h, w)) of the cells around points (N, 2) in cell coordinates, one cell of margin, cut to
    the grid; None if that leaves nothing."""
    if len(points_uv) == 0:
        return None
    low = np.floor(points_uv.min(axis=0)).astype(int) - 1
    high = np.floor(points_uv.max(axis=0)).astype(int) + 2
    col0, row0 = max(low[0], 0), max(low[1], 0)
    col1, row1 = min(high[0], frame.shape[1]), min(high[1], frame.shape[0])
    if col1 <= col0 or row1 <= row0:
        return None
    return row0, col0, (row1 - row0, col1 - col0)


def _fixed(points_uv: np.ndarray) -> np.ndarray:
    """Cell coordinates -> OpenCV fixed-point pixel coordinates (pixel centres sit at integers)."""
    return np.round((points_uv - 0.5) * (1 << _SUBPIXEL_BITS)).astype(np.int32)
