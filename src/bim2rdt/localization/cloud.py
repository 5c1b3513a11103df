"""BIM-anchored localization of a point cloud: a registered scan (a 360 degree terrestrial scan) or an RGB-D
frame's points, in the sensor frame, fixed on the permanent elements the sensor could see from where it stood.

The same 4-DoF fix as :func:`bim2rdt.localization.localize` (yaw-only registration: ``up`` fixes roll and pitch,
the view fixes yaw and position; then the covariance and the directions the view cannot fix), with what a scan
needs that a camera frame does not:

1. no image: the cloud is thinned on a voxel grid and its normals come from its neighbours (PCA);
2. no field of view: the BIM is ray cast from the sensor over the whole sphere, and only the directions the cloud
   itself covers (placed by the current pose, widened by ``cloud_margin_deg``) are kept, so a scan looking all
   round sees all round and a frame sees its cone, without the localizer assuming either;
3. the model's other bodies (furniture, site objects, spaces aside) hide what lies behind them: the ray cast
   stops on them and keeps no sample there. A built-in wardrobe half a metre in front of a wall otherwise lends
   the wall its front face, and the fix slides half a metre (office1: the inferred right wall behind the
   wardrobe). An object the BIM has that is not there only costs a patch of the map, never a wrong pair.
"""

from __future__ import annotations

from collections import OrderedDict
from functools import lru_cache
from dataclasses import dataclass

import numpy as np
import trimesh

from bim2rdt.bim import BimModel
from bim2rdt.localization.config import LocalizationConfig
from bim2rdt.localization.core import Localization, behind_fraction, checked_up, fix_pose, rigid_prior
from bim2rdt.localization.errors import LocalizationError, Refusal
from bim2rdt.localization.surfaces import GRAZING_COS, PermanentMap, SurfaceSamples, permanent_map
from bim2rdt.registration import (any_within, cube_means, nearest_neighbours, neighbour_scatter, points_in_range,
                                  smallest_axes)

_CACHE_SIZE = 4


@dataclass(frozen=True)
class ScanPoints:
    """The cloud as the localizer uses it: points (N, 3) and unit normals (N, 3, NaN where the neighbourhood is
    not flat) in the sensor frame, metres, normals turned towards the sensor."""

    points: np.ndarray
    normals: np.ndarray

    @property
    def directions(self) -> np.ndarray:
        """Unit rays (N, 3) from the sensor to each point."""
        return self.points / np.linalg.norm(self.points, axis=1, keepdims=True)


def localize_cloud(cloud: object, model: BimModel, prior_T_world_sensor: np.ndarray,
                   up: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 1.0),
                   config: LocalizationConfig | None = None, scene: OccludedMap | None = None) -> Localization:
    """Fix the pose of the sensor that took ``cloud`` on the permanent elements of ``model``, from
    ``prior_T_world_sensor`` (4, 4), with ``up`` the world up measured by the sensor's IMU (the prior's roll and
    pitch are kept). Returns the same :class:`Localization` as :func:`~bim2rdt.localization.localize` (the same
    fix: :func:`~bim2rdt.localization.core.fix_pose`); raises :class:`LocalizationError` with the reason.

    Args:
        cloud: A :class:`ScanPoints` (what :func:`scan_points` made of a cloud, used as it is), an (N, 3) array,
            or anything with ``.points`` (N, 3): the sensor frame, metres, NaN rows are no return.
        model: The BIM, loaded with geometry.
        prior_T_world_sensor: 4x4 sensor-to-world prior, metres.
        up: The world up measured by the sensor's IMU, a unit 3-vector.
        config: Localization's settings; None uses the defaults.
        scene: The model's :class:`OccludedMap` when the caller holds it (verify builds it once per run); None
            builds or reuses the cached one.

    Returns:
        The fix: ``pose`` (``T_world_sensor``, 4x4), covariance, information, free directions and residual.

    Raises:
        LocalizationError: A bad cloud or prior, too few returns in range, no permanent element in view, or a
            correction beyond the basin; the message gives the reason, ``kind`` its kind.
    """
    cfg = config or LocalizationConfig()
    prior, up_world = rigid_prior(prior_T_world_sensor), checked_up(up)
    scan = cloud if isinstance(cloud, ScanPoints) else scan_points(_points_of(cloud), cfg)
    return fix_pose(CloudView(scan, scene or OccludedMap.of(model), cfg), prior, up_world, cfg)


@dataclass(frozen=True)
class CloudView:
    """A cloud as the fix sees it (:class:`~bim2rdt.localization.core.SensorView`): its thinned points and PCA
    normals, and the BIM ray cast over the directions the cloud covers (``cloud_ray_deg`` apart, twice that for
    the coarse pass), the model's other bodies hiding what lies behind them."""

    scan: ScanPoints
    scene: OccludedMap
    cfg: LocalizationConfig
    sensor: str = "sensor"
    returns: str = "thinned points"
    needs_normals: bool = False

    @property
    def points(self) -> np.ndarray:
        """(N, 3) thinned points, sensor frame, metres."""
        return self.scan.points

    @property
    def normals(self) -> np.ndarray:
        """(N, 3) their unit normals, NaN where not flat."""
        return self.scan.normals

    def visible(self, T_world_sensor: np.ndarray, coarse: bool) -> SurfaceSamples:
        """The permanent surface seen from ``T_world_sensor`` over the cloud's directions.

        Args:
            T_world_sensor: 4x4 sensor pose.
            coarse: Rays twice ``cloud_ray_deg`` apart instead of ``cloud_ray_deg``.

        Returns:
            The samples.
        """
        ray_deg = (2 if coarse else 1) * self.cfg.cloud_ray_deg
        return self.scene.visible(T_world_sensor, self.scan.directions, ray_deg, self.cfg.cloud_margin_deg,
                                  self.cfg.max_range * 1.2)

    def behind(self, T_world_sensor: np.ndarray, tolerance: float) -> float:
        """Fraction of the points beyond the first permanent surface on their ray
        (:func:`~bim2rdt.localization.core.behind_fraction`).

        Args:
            T_world_sensor: 4x4 sensor pose.
            tolerance: Metres past the surface allowed.

        Returns:
            The fraction.
        """
        return behind_fraction(self.scan.points, T_world_sensor, self.scene.permanent, tolerance)


def _points_of(cloud) -> np.ndarray:
    """A cloud's points: an array itself, or its ``.points``."""
    if isinstance(cloud, np.ndarray):
        return cloud
    points = getattr(cloud, "points", None)
    if points is None:
        raise LocalizationError(f"expected a cloud with .points (N, 3), got {type(cloud).__name__}")
    return points


def scan_points(points_sensor: np.ndarray, cfg: LocalizationConfig) -> ScanPoints:
    """The returns in [min_range, max_range], one per ``cloud_voxel`` cube (their mean), at most ``cloud_points``
    of them (an even draw), with PCA normals.

    Args:
        points_sensor: (N, 3) points in the sensor frame, metres (NaN rows are no return); a cloud with
            ``.points`` is taken too.
        cfg: Localization's settings.

    Returns:
        The thinned points with their normals.

    Raises:
        LocalizationError: Not (N, 3), or fewer than ``min_points`` returns in range.
    """
    points = np.asarray(_points_of(points_sensor), dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3:
        raise LocalizationError(f"cloud.points must be (N, 3) metres, got shape {points.shape}")
    points = np.ascontiguousarray(points)
    keep = points_in_range(points, cfg.min_range, cfg.max_range)  # finite, and norm's lengths
    points = points if keep.all() else points[keep]
    if len(points) < cfg.min_points:
        raise LocalizationError(f"the cloud has {len(points)} returns in {cfg.min_range}-{cfg.max_range} m of the "
                                f"sensor, need {cfg.min_points}", Refusal.TOO_FEW_RETURNS)
    thinned = voxel_means(points, cfg.cloud_voxel)
    if len(thinned) > cfg.cloud_points:
        thinned = thinned[np.random.default_rng(0).choice(len(thinned), cfg.cloud_points, replace=False)]
    return ScanPoints(thinned, pca_normals(thinned, cfg.cloud_normal_neighbours))


def voxel_means(points: np.ndarray, voxel: float) -> np.ndarray:
    """One point per occupied ``voxel`` cube (the mean of its points): a scan's density falls with range and a
    frame's is highest near the camera; the fix should weigh surfaces, not the sensor's sampling.

    Args:
        points: (N, 3) points, metres.
        voxel: The cube's side, metres.

    Returns:
        (M, 3) the cubes' mean points, none for no points (an object in view owning none of a frame's).
    """
    if len(points) == 0:
        return np.zeros((0, 3))
    points = np.ascontiguousarray(points, dtype=np.float64)
    means = cube_means(points, voxel, DENSE_CUBES)  # the table's numbering, compiled
    if means is not None:
        return means
    cells = np.floor(points / voxel).astype(np.int64)
    cells -= cells.min(axis=0)
    size = cells.max(axis=0) + 1
    keys = (cells[:, 0] * size[1] + cells[:, 1]) * size[2] + cells[:, 2]  # one integer per cube: a 1-D unique
    inverse, counts = _cube_index(keys, int(np.prod(size)))
    # bincount sums in the points' order, as np.add.at did: the same means, 3x faster
    sums = np.stack([np.bincount(inverse, weights=points[:, axis], minlength=len(counts)) for axis in range(3)],
                    axis=1)
    return sums / counts[:, None]


DENSE_CUBES = 2_000_000
"""Up to this many cubes in the points' box, :func:`voxel_means` numbers the occupied ones with a table over the
box (a count per cube, compiled: :func:`bim2rdt.registration.kernels.cube_means`) instead of sorting the keys:
the same numbering and means, a quarter of the time on a frame's 254,000 points (decision 0050)."""


def _cube_index(keys: np.ndarray, cubes: int) -> tuple[np.ndarray, np.ndarray]:
    """Each key's rank among the distinct keys (ascending) and each distinct key's count: ``np.unique``'s inverse
    and counts. Keys lie in [0, ``cubes``)."""
    if cubes > DENSE_CUBES:
        _, inverse, counts = np.unique(keys, return_inverse=True, return_counts=True)
        return inverse.reshape(-1), counts
    every = np.bincount(keys, minlength=cubes)
    occupied = np.flatnonzero(every)
    rank = np.empty(cubes, dtype=np.intp)
    rank[occupied] = np.arange(len(occupied))
    return rank[keys], every[occupied]


def pca_normals(points: np.ndarray, neighbours: int) -> np.ndarray:
    """Unit normals (N, 3) from each point's ``neighbours`` nearest (the smallest principal axis), turned towards
    the sensor at the origin; NaN where the neighbourhood is not a plane (its smallest spread is more than a
    third of the middle one: an edge, a corner, clutter)."""
    k = min(neighbours, len(points))
    points = np.ascontiguousarray(points, dtype=np.float64)
    values, normals = smallest_axes(neighbour_scatter(points, nearest_neighbours(points, k)))  # compiled
    normals = np.where((np.einsum("ni,ni->n", normals, points) > 0)[:, None], -normals, normals)
    flat = values[:, 0] <= values[:, 1] / 9.0
    return np.where(flat[:, None], normals, np.nan)


@dataclass(frozen=True)
class OccludedMap:
    """The permanent map (:class:`PermanentMap`) with every other body of the model as an occluder: ``mesh``
    holds both, ``face_owner`` the map element's index per face, or -1 - k for the k-th of ``occluder_ids``."""

    permanent: PermanentMap
    mesh: trimesh.Trimesh
    face_owner: np.ndarray
    occluder_ids: tuple[str, ...]

    @classmethod
    def of(cls, model: BimModel) -> OccludedMap:
        """The model's map, built once per model object (the last few are kept).

        Args:
            model: The BIM, loaded with geometry.

        Returns:
            Its map.
        """
        key = (model.digest, id(model))
        if key not in _MAPS:
            _MAPS[key] = cls._build(model)
            while len(_MAPS) > _CACHE_SIZE:
                _MAPS.popitem(last=False)
        _MAPS.move_to_end(key)
        return _MAPS[key]

    @classmethod
    def _build(cls, model: BimModel) -> OccludedMap:
        permanent = permanent_map(model)
        in_map = set(permanent.element_ids)
        others = [el.global_id for el in model.elements
                  if el.global_id not in in_map and el.ifc_class not in NOT_OCCLUDING and model.has_mesh(el.global_id)]
        vertices, faces = [permanent.mesh.vertices], [permanent.mesh.faces]
        owner, offset = [permanent.face_owner], len(permanent.mesh.vertices)
        for k, global_id in enumerate(others):
            v, f = model.mesh(global_id)
            vertices.append(np.asarray(v, dtype=np.float64))
            faces.append(np.asarray(f) + offset)
            owner.append(np.full(len(f), -1 - k))
            offset += len(v)
        mesh = trimesh.Trimesh(np.concatenate(vertices), np.concatenate(faces), process=False)
        owner = np.concatenate(owner)
        keep = mesh.area_faces > 1e-12
        return cls(permanent, trimesh.Trimesh(mesh.vertices, mesh.faces[keep], process=False), owner[keep],
                   tuple(others))

    def visible(self, T_world_sensor: np.ndarray, directions_sensor: np.ndarray, ray_deg: float, margin_deg: float,
                max_range: float) -> SurfaceSamples:
        """The permanent surface seen from ``T_world_sensor``'s position: first hits of rays ``ray_deg`` apart
        over the directions within ``margin_deg`` of the cloud's, within ``max_range`` m, on a permanent element
        (not an occluder), grazing hits dropped.

        Args:
            T_world_sensor: 4x4 sensor pose, metres.
            directions_sensor: (N, 3) unit directions the cloud covers, sensor frame.
            ray_deg: Spacing of the cast rays, degrees.
            margin_deg: How far beyond the cloud's directions rays are cast, degrees.
            max_range: Farthest hit kept, metres.

        Returns:
            World samples, their normals (towards the sensor) and elements.
        """
        origin = T_world_sensor[:3, 3]
        directions = covered(_sphere(ray_deg), directions_sensor @ T_world_sensor[:3, :3].T, margin_deg)
        if len(directions) == 0:
            return SurfaceSamples(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, int))
        face = self.mesh.ray.intersects_first(np.broadcast_to(origin, directions.shape), directions)
        hit = face >= 0
        face, directions = face[hit], directions[hit]
        normals = self.mesh.face_normals[face]
        corner = self.mesh.vertices[self.mesh.faces[face, 0]]
        towards = np.einsum("ni,ni->n", normals, directions)
        with np.errstate(divide="ignore", invalid="ignore"):
            depth = np.einsum("ni,ni->n", normals, corner - origin) / towards
        keep = (self.face_owner[face] >= 0) & (depth > 0) & (depth <= max_range) & (np.abs(towards) >= GRAZING_COS)
        normals = np.where((towards > 0)[:, None], -normals, normals)
        points = origin + directions[keep] * depth[keep, None]
        return SurfaceSamples(points, normals[keep], self.face_owner[face[keep]])

    def occluder_hits(self, T_world_sensor: np.ndarray, directions_sensor: np.ndarray, ray_deg: float,
                      max_range: float) -> dict[str, int]:
        """How many rays ``ray_deg`` apart, over the directions the sensor covers, first hit each occluder within
        ``max_range``: which of the model's objects the sensor could see from ``T_world_sensor``, each behind the
        walls and the other objects.

        Args:
            T_world_sensor: 4x4 sensor pose, metres.
            directions_sensor: (N, 3) unit directions the sensor covers, sensor frame.
            ray_deg: Spacing of the cast rays, degrees.
            max_range: Farthest hit counted, metres.

        Returns:
            GlobalId -> rays that first hit it (occluders hit by none are left out).
        """
        origin = T_world_sensor[:3, 3]
        directions = covered(_sphere(ray_deg), directions_sensor @ T_world_sensor[:3, :3].T, ray_deg)
        if len(directions) == 0:
            return {}
        locations, rays, faces = self.mesh.ray.intersects_location(np.broadcast_to(origin, directions.shape),
                                                                   directions, multiple_hits=False)
        near = np.linalg.norm(locations - origin, axis=1) <= max_range
        owner = self.face_owner[faces[near]]
        counts = np.bincount(-1 - owner[owner < 0], minlength=len(self.occluder_ids))
        return {global_id: int(n) for global_id, n in zip(self.occluder_ids, counts) if n}


NOT_OCCLUDING = frozenset({"IfcSpace", "IfcOpeningElement", "IfcVirtualElement", "IfcAnnotation", "IfcSite",
                           "IfcBuilding", "IfcBuildingStorey", "IfcSpatialZone", "IfcZone", "IfcGrid"})
"""Bodies a sensor sees through: spaces, voids, annotations."""

_MAPS: OrderedDict[tuple[str, int], OccludedMap] = OrderedDict()


def sphere_directions(step_deg: float) -> np.ndarray:
    """Unit vectors spread evenly over the sphere about ``step_deg`` apart (a Fibonacci lattice).

    Args:
        step_deg: The angle between neighbouring directions, degrees.

    Returns:
        (K, 3) unit vectors.
    """
    step = np.deg2rad(step_deg)
    count = max(16, int(round(4 * np.pi / step**2)))
    k = np.arange(count) + 0.5
    z = 1 - 2 * k / count
    azimuth = np.pi * (1 + 5**0.5) * k
    ring = np.sqrt(1 - z**2)
    return np.stack([ring * np.cos(azimuth), ring * np.sin(azimuth), z], axis=1)


def load_lattices(cfg: LocalizationConfig, *steps_deg: float) -> None:
    """Build now the ray lattices (:func:`sphere_directions`) a fix of a cloud with ``cfg`` casts over (every
    ``cloud_ray_deg``, and twice that for the coarse pass) and any other ``steps_deg``: constants of the settings,
    kept once built (~3 ms each), which a long run (``verify``) builds in its setup, not in its first frame.

    Args:
        cfg: Localization's settings.
        *steps_deg: Other lattice spacings the run casts over, degrees.
    """
    for step in (cfg.cloud_ray_deg, 2 * cfg.cloud_ray_deg, *steps_deg):
        _sphere(step)


@lru_cache(maxsize=8)
def _sphere(step_deg: float) -> np.ndarray:
    """:func:`sphere_directions`, computed once per step (read-only): every fix casts over the same lattice."""
    directions = sphere_directions(step_deg)
    directions.flags.writeable = False
    return directions


def covered(directions: np.ndarray, seen: np.ndarray, margin_deg: float) -> np.ndarray:
    """The ``directions`` (unit) within ``margin_deg`` of any of ``seen`` (unit): where the sensor looked.

    A camera's view is a cap of the sphere: only the directions within the cap's radius plus the margin of its
    centre are asked (a direction nearer than the margin to a seen one is nearer than that to the centre), each
    by :func:`~bim2rdt.registration.matching.any_within` (pykdtree's answers, compiled over a grid of cubes): a
    Kinect frame asks a tenth of the 165,000 directions of a 0.5-degree lattice."""
    margin = np.deg2rad(margin_deg)
    chord = 2 * np.sin(margin / 2)
    centre = seen.sum(axis=0)
    length = float(np.linalg.norm(centre))
    if length > 1e-9:
        centre = centre / length
        radius = float(np.arccos(np.clip(seen @ centre, -1.0, 1.0)).max())
        if radius + margin + 1e-6 < np.pi:
            directions = directions[directions @ centre >= np.cos(radius + margin + 1e-6)]
    return directions[any_within(seen, directions, chord)]
