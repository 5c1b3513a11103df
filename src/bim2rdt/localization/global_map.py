"""A storey's plan as the global search sees it: the BIM's permanent wall-facing surfaces in a height band above
the floor, rasterised, with the free space a sensor can stand in.

Per storey, on a grid of ``resolution`` m (rows along world y, columns along x):

- ``likelihood``: exp(-d^2 / 2 sigma^2) of each cell's distance d to the nearest surface in the band: the
  permanent map's, and the model's other bodies' (they explain the points on them, as they occlude in the fix);
- ``solid``: the cells a sensor ray cannot cross: those whose centre lies inside a permanent element in the band
  (on the inner side of the nearest sideways face). Not grown: a ray that passes a column's edge or a door's
  jamb a few centimetres off is not a ray through it (grown by a cell, such rays cost the true place more than
  a wrong one: the simulated tour's stations 6 and 16);
- ``free``: the cells a sensor can stand in: over the storey's floor (its slabs' top faces), at least
  ``clearance`` from any surface. This is the planning grid's free space, built from the same permanent map here
  because localization sits below planning in the layers.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
import trimesh
from scipy import ndimage
from scipy.spatial import cKDTree

from bim2rdt.bim import BimModel
from bim2rdt.localization.errors import LocalizationError
from bim2rdt.localization.surfaces import PermanentMap

_CACHE_SIZE = 8
_SAMPLE_SPACING = 0.04


@dataclass(frozen=True)
class StoreyPlan:
    """One storey's rasters (see the module's note); ``origin`` (x, y) is the grid's lower-left corner, world m;
    ``floor_z`` the floor's world height, m."""

    name: str
    floor_z: float
    origin: np.ndarray
    resolution: float
    likelihood: np.ndarray
    solid: np.ndarray
    free: np.ndarray

    def centre(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """World (x, y) (N, 2) of cell centres."""
        return self.origin + (np.stack([cols, rows], axis=1) + 0.5) * self.resolution


def storey_plans(model: BimModel, storey: str | None, resolution: float, band: tuple[float, float], sigma: float,
                 clearance: float) -> list[StoreyPlan]:
    """The plans of every storey of ``model`` (or only the one named ``storey``), built once per model and
    settings.

    Args:
        model: The BIM, loaded with geometry.
        storey: A storey's name or GlobalId; None searches every storey.
        resolution: Cell edge, m.
        band: (low, high) heights above the floor whose surfaces are drawn, m.
        sigma: Width of the surface likelihood, m.
        clearance: Least distance of a free cell from a surface, m.

    Returns:
        One :class:`StoreyPlan` per storey with a floor.

    Raises:
        LocalizationError: No such storey, or no floor found in the model.
    """
    key = (model.digest, id(model), storey, resolution, tuple(band), sigma, clearance)
    if key not in _PLANS:
        _PLANS[key] = _build(model, storey, resolution, band, sigma, clearance)
        while len(_PLANS) > _CACHE_SIZE:
            _PLANS.popitem(last=False)
    _PLANS.move_to_end(key)
    return _PLANS[key]


_PLANS: OrderedDict[tuple, list[StoreyPlan]] = OrderedDict()


def _build(model: BimModel, storey: str | None, resolution: float, band: tuple[float, float], sigma: float,
           clearance: float) -> list[StoreyPlan]:
    from bim2rdt.localization.cloud import OccludedMap

    scene = OccludedMap.of(model)
    levels = floor_levels(model, scene.permanent, storey)
    plans = [_plan(scene, name, z, resolution, band, sigma, clearance) for name, z in levels]
    plans = [plan for plan in plans if plan is not None]
    if not plans:
        raise LocalizationError(f"{model.path.name}: no floor with walls around it to search (the global search "
                                "needs slabs and walls in the permanent map)")
    return plans


def floor_levels(model: BimModel, surfaces: PermanentMap, storey: str | None) -> list[tuple[str, float]]:
    """(storey name, floor height m) of each storey: the top of the permanent map's upward faces with the most
    area within 0.6 m of its elevation (the elevation itself when none). A model without storeys has one level,
    its largest upward face height."""
    mesh = surfaces.mesh
    up_faces = mesh.face_normals[:, 2] > 0.95
    heights = mesh.triangles_center[up_faces, 2]
    areas = mesh.area_faces[up_faces]
    storeys = [s for s in model.storeys if s.elevation is not None]
    if storey is not None:
        storeys = [s for s in model.storeys if storey in (s.name, s.global_id)]
        if not storeys:
            names = ", ".join(str(s.name) for s in model.storeys) or "none"
            raise LocalizationError(f"{model.path.name} has no storey {storey!r} (its storeys: {names})")
    if not storeys:
        return [("the model", _mode(heights, areas, None))] if len(heights) else []
    return [(s.name or s.global_id, _mode(heights, areas, s.elevation)) for s in storeys]


def _mode(heights: np.ndarray, areas: np.ndarray, near: float | None) -> float:
    """The height (5 cm bins) holding the most area, among those within 0.6 m of ``near`` (any when None)."""
    keep = np.ones(len(heights), bool) if near is None else np.abs(heights - near) <= 0.6
    if not keep.any():
        return float(near)
    bins = np.round(heights[keep] / 0.05).astype(np.int64)
    values, inverse = np.unique(bins, return_inverse=True)
    return float(values[np.argmax(np.bincount(inverse, weights=areas[keep]))] * 0.05)


def _plan(scene, name: str, floor_z: float, resolution: float, band: tuple[float, float],
          sigma: float, clearance: float) -> StoreyPlan | None:
    """The storey's rasters: its surfaces in the band are the permanent map's and the model's other bodies'
    (a built-in wardrobe in front of a wall explains the points on it, as it occludes in the fix); its floor and
    clearance are the permanent map's alone."""
    walls, _ = _band_samples(scene.mesh, floor_z + band[0], floor_z + band[1])
    permanent, outward = _band_samples(scene.permanent.mesh, floor_z + band[0], floor_z + band[1])
    floor = _floor_samples(scene.permanent.mesh, floor_z)
    if len(walls) == 0 or len(floor) == 0:
        return None
    low = np.minimum(walls.min(axis=0), floor.min(axis=0)) - 1.0
    high = np.maximum(walls.max(axis=0), floor.max(axis=0)) + 1.0
    shape = tuple((np.ceil((high - low) / resolution)).astype(int)[::-1])
    surface = _raster(walls, low, resolution, shape)
    distance = ndimage.distance_transform_edt(~surface) * resolution
    structure = _raster(permanent, low, resolution, shape)
    clear = ndimage.distance_transform_edt(~structure) * resolution > clearance
    on_floor = ndimage.binary_closing(_raster(floor, low, resolution, shape), iterations=2)
    solid = _inside(permanent, outward, low, resolution, shape)
    return StoreyPlan(name, float(floor_z), low, resolution, np.exp(-0.5 * (distance / sigma) ** 2),
                      solid, on_floor & clear & ~solid)


def _band_samples(mesh: trimesh.Trimesh, low: float, high: float) -> tuple[np.ndarray, np.ndarray]:
    """Plan (x, y) samples (N, 2) of the faces that face sideways and reach into [low, high] m, about 4 cm apart,
    and their faces' outward normals in plan (N, 2), unit."""
    z = mesh.triangles[:, :, 2]
    faces = (np.abs(mesh.face_normals[:, 2]) < 0.3) & (z.max(axis=1) >= low) & (z.min(axis=1) <= high)
    points, owner = _sample(mesh, faces, with_faces=True)
    keep = (points[:, 2] >= low) & (points[:, 2] <= high)
    normals = mesh.face_normals[np.nonzero(faces)[0][owner[keep]], :2] if len(owner) else np.zeros((0, 2))
    normals = normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-9)
    return points[keep, :2], normals


def _inside(samples: np.ndarray, outward: np.ndarray, origin: np.ndarray, resolution: float,
            shape: tuple[int, int], reach: float = 0.5) -> np.ndarray:
    """The cells (rows, cols) whose centre lies within ``reach`` m of a sideways face and on the inner side of
    the nearest one: inside a wall or column in plan. Far from every face nothing is solid (a body thicker
    than 2 x ``reach`` keeps a free core, which no ray reaches without crossing its faces first)."""
    solid = np.zeros(shape, bool)
    if len(samples) == 0:
        return solid
    rows, cols = np.nonzero(np.ones(shape, bool))
    centres = origin + (np.stack([cols, rows], axis=1) + 0.5) * resolution
    distance, nearest = cKDTree(samples).query(centres, distance_upper_bound=reach)
    near = np.isfinite(distance)
    side = np.einsum("ij,ij->i", centres[near] - samples[nearest[near]], outward[nearest[near]])
    solid[rows[near], cols[near]] = side < 0
    return solid


def _floor_samples(mesh: trimesh.Trimesh, floor_z: float) -> np.ndarray:
    """Plan (x, y) samples of the upward faces at the floor's height (within 10 cm)."""
    faces = (mesh.face_normals[:, 2] > 0.95) & (np.abs(mesh.triangles_center[:, 2] - floor_z) < 0.1)
    return _sample(mesh, faces)[:, :2]


def _sample(mesh: trimesh.Trimesh, faces: np.ndarray, with_faces: bool = False):
    """Samples (N, 3) of the ``faces`` (mask) of ``mesh``, ``_SAMPLE_SPACING`` apart on average; with
    ``with_faces`` also each sample's index among the masked faces (N,)."""
    if not faces.any():
        return (np.zeros((0, 3)), np.zeros(0, int)) if with_faces else np.zeros((0, 3))
    part = trimesh.Trimesh(mesh.vertices, mesh.faces[faces], process=False)
    count = max(1, int(part.area / _SAMPLE_SPACING**2))
    points, owner = trimesh.sample.sample_surface(part, count, seed=0)
    points = np.asarray(points, dtype=np.float64)
    return (points, np.asarray(owner)) if with_faces else points


def _raster(xy: np.ndarray, origin: np.ndarray, resolution: float, shape: tuple[int, int]) -> np.ndarray:
    cells = np.floor((xy - origin) / resolution).astype(int)
    inside = (cells[:, 0] >= 0) & (cells[:, 0] < shape[1]) & (cells[:, 1] >= 0) & (cells[:, 1] < shape[0])
    image = np.zeros(shape, bool)
    image[cells[inside, 1], cells[inside, 0]] = True
    return image
