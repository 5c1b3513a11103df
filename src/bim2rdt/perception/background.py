"""What the BIM explains in a depth frame: scan-vs-BIM against the building's permanent elements.

Every pixel's ray is cast into the BIM's walls, slabs, columns and doors (their own IFC meshes, with embree): a
measured point within ``tolerance`` of the surface the BIM puts on that ray (distance along the surface normal,
so a floor at grazing incidence is judged as fairly as a wall ahead) is explained; a point in front of it is
something the BIM does not have; a point behind it (through a door the BIM shows shut) is not an object either.
Points on the storey's slab, whose height comes from the BIM's slabs (not a constant), are explained too.
"""

from __future__ import annotations

import numpy as np
import trimesh

from bim2rdt.bim import BimModel
from bim2rdt.perception.structure import permanent_elements
from bim2rdt.perception.surfaces import KnownSurface
from bim2rdt.registration import plane_hit_depths

SLAB_CLASSES = ("IfcSlab", "IfcSlabStandardCase", "IfcSlabElementedCase")


class BimStructure:
    """The model's permanent elements as one ray-castable world mesh, and the tops of its slabs."""

    def __init__(self, model: BimModel) -> None:
        elements = permanent_elements(model)
        meshes = [trimesh.Trimesh(*model.mesh(el.global_id), process=False) for el in elements]
        self.mesh = trimesh.util.concatenate(meshes) if meshes else None
        self.surfaces = [KnownSurface.of_element(model, el) for el in elements]
        self.slabs = [_footprint_and_top(mesh) for el, mesh in zip(elements, meshes) if el.ifc_class in SLAB_CLASSES]
        self.storey_elevations = sorted(s.elevation for s in model.storeys if s.elevation is not None)

    def slab_height(self, position_world: np.ndarray) -> float:
        """Height (m) of the floor under ``position_world`` (the camera, an object): the top of the highest
        slab whose plan covers it and lies below it; else the highest storey elevation below it; else 0."""
        x, y, z = np.asarray(position_world, dtype=float)[:3]
        tops = [top for x0, y0, x1, y1, top in self.slabs if x0 <= x <= x1 and y0 <= y <= y1 and top <= z + 0.05]
        if tops:
            return max(tops)
        below = [e for e in self.storey_elevations if e <= z]
        return below[-1] if below else 0.0

    def cast(self, origin: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Ray parameters (N,) of the first BIM surface along each ray (NaN: none) and its unit normals (N, 3)."""
        if self.mesh is None or len(directions) == 0:
            return np.full(len(directions), np.nan), np.zeros((len(directions), 3))
        face = self.mesh.ray.intersects_first(np.broadcast_to(origin, directions.shape), directions)
        return hit_depths(self.mesh, face, origin, directions)


def hit_depths(mesh: trimesh.Trimesh, face: np.ndarray, origin: np.ndarray, directions: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """Ray parameters t (N,) at the plane of the triangle of ``mesh`` each ray ``origin`` + t ``directions`` (N, 3)
    first hit (``face`` (N,), -1: none, t NaN) and the triangle's unit normal (N, 3; zeros for none):
    t = n . (v0 - origin) / n . d, compiled (:func:`bim2rdt.registration.kernels.hit_depths`, decision 0050).

    Args:
        mesh: The mesh the rays were cast on.
        face: (N,) the first face each ray hit, -1 for none.
        origin: (3,) the rays' origin, metres.
        directions: (N, 3) the rays' directions.

    Returns:
        (t (N,), normals (N, 3)).
    """
    return plane_hit_depths(face, mesh.face_normals, mesh.vertices, mesh.faces, origin, directions)


_STRUCTURES: dict[tuple[int, str], BimStructure] = {}


def structure_for(model: BimModel) -> BimStructure:
    """The :class:`BimStructure` of ``model``, built once (its mesh and the ray caster's scene are kept).

    Args:
        model: The BIM, loaded with geometry.

    Returns:
        Its building's structure (walls, slabs: what explains a depth point).
    """
    key = (id(model), model.digest)
    if key not in _STRUCTURES:
        if len(_STRUCTURES) >= 4:
            _STRUCTURES.pop(next(iter(_STRUCTURES)))
        _STRUCTURES[key] = BimStructure(model)
    return _STRUCTURES[key]


def explained(structure: BimStructure, origin: np.ndarray, directions: np.ndarray, measured: np.ndarray,
              tolerance: float, sigma: np.ndarray, slab_height: float, slab_clearance: float) -> np.ndarray:
    """(N,) bool: rays whose measured point (ray parameter ``measured``, the camera z for pixel rays) the BIM
    explains: on a permanent surface (within ``tolerance`` m plus 3 x the depth noise ``sigma`` (N,) seen
    along the surface normal, so a floor at grazing incidence is not given the tolerance of a wall ahead),
    behind one, or on the slab (below ``slab_height`` + ``slab_clearance``). The surface on the point's own ray
    is tested first; the points it leaves are tested against every surface in 3-D (:func:`on_any_surface`).

    Args:
        structure: The building (:func:`structure_for`).
        origin: (3,) the sensor's position, world metres.
        directions: (N, 3) world rays.
        measured: (N,) the ray parameter of each measured point.
        tolerance: Metres off a surface a point may lie.
        sigma: (N,) each point's depth noise, metres.
        slab_height: World z of the floor under the sensor, metres.
        slab_clearance: Metres above it that are still the slab.

    Returns:
        (N,) bool, True where the building explains the point.
    """
    t, normals = structure.cast(origin, directions)
    points = origin + directions * measured[:, None]
    along_normal = np.abs(np.einsum("ni,ni->n", directions, normals))
    with np.errstate(invalid="ignore"):
        on_or_behind = (measured - t) * along_normal > -(tolerance + 3.0 * sigma * along_normal)
    out = np.where(np.isfinite(t), on_or_behind, False) | (points[:, 2] < slab_height + slab_clearance)
    rest = np.flatnonzero(~out)
    out[rest] = on_any_surface(structure.surfaces, points[rest], directions[rest], tolerance, sigma[rest])
    return out


def on_any_surface(surfaces: list[KnownSurface], points_world: np.ndarray, directions: np.ndarray,
                   tolerance: float, sigma: np.ndarray) -> np.ndarray:
    """(N,) bool: measured points (N, 3) within ``tolerance`` plus 3 x the depth noise ``sigma`` (N,) of any of
    the ``surfaces``, by the true point-to-triangle distance. The noise moves a point along its ray
    (``directions`` (N, 3), scaled so that a step of 1 in depth is one of them), so it counts as much as the ray
    runs along the way from the triangle to the point: the per-ray test's "seen along the normal", at an edge.

    Why not only the surface on the point's own ray: at a silhouette a pixel's ray passes just beside a column
    and hits the wall behind, while the depth it measured (a mixed pixel, a camera pose a few mm off) lies on
    the column: in front of the wall, so the ray alone keeps it, and a strip of the column's edge became an
    object (the demo's station 2: 129 points of Column C11's corner, which a tripod leg fits to a few mm)."""
    out = np.zeros(len(points_world), dtype=bool)
    if len(points_world) == 0:
        return out
    reach = tolerance + 3.0 * float(np.max(sigma * np.linalg.norm(directions, axis=1)))
    by_x = np.argsort(points_world[:, 0])  # an element is measured only against the points across its x-range
    xs = points_world[by_x, 0]
    for surface in surfaces:
        first, last = np.searchsorted(xs, (surface.bounds[0, 0] - reach, surface.bounds[1, 0] + reach))
        if first == last:
            continue
        across = by_x[first:last]
        index, closest = surface.closest_points(points_world[across], reach)
        near = across[index]  # (K,) a point for each of its triangles within reach
        offset = points_world[near] - closest
        gap = np.linalg.norm(offset, axis=1)
        along = np.abs(np.einsum("ni,ni->n", directions[near], offset)) / np.maximum(gap, 1e-12)
        out[near[gap <= tolerance + 3.0 * sigma[near] * along]] = True
    return out


def _footprint_and_top(mesh: trimesh.Trimesh) -> tuple[float, float, float, float, float]:
    (x0, y0, _), (x1, y1, top) = mesh.bounds
    return float(x0), float(y0), float(x1), float(y1), float(top)
