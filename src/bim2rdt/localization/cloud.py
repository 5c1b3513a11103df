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
from dataclasses import dataclass

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from bim2rdt.bim import BimModel
from bim2rdt.localization.config import LocalizationConfig
from bim2rdt.localization.errors import LocalizationError
from bim2rdt.localization.fix import (Localization, _observability, _pairs, _rigid_prior, _unit_up, _within,
                                      _within_basin)
from bim2rdt.localization.surfaces import GRAZING_COS, PermanentMap, SurfaceSamples, permanent_map
from bim2rdt.registration import IcpConfig, RegistrationError, register
from bim2rdt.registration.so3 import invert_poses

_CACHE_SIZE = 4


@dataclass(frozen=True)
class ScanPoints:
    """The cloud as the localizer uses it: points (N, 3) and unit normals (N, 3, NaN where the neighbourhood is
    not flat) in the sensor frame, metres, normals turned towards the sensor."""

    points: np.ndarray
    normals: np.ndarray

    @property
    def directions(self) -> np.ndarray:
        return self.points / np.linalg.norm(self.points, axis=1, keepdims=True)


def localize_cloud(cloud: object, model: BimModel, prior_T_world_sensor: np.ndarray,
                   up: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 1.0),
                   config: LocalizationConfig | None = None) -> Localization:
    """Fix the pose of the sensor that took ``cloud`` (anything with ``.points`` (N, 3), metres, sensor frame;
    NaN rows are no return) on the permanent elements of ``model``, from ``prior_T_world_sensor`` (4, 4), with
    ``up`` the world up measured by the sensor's IMU (the prior's roll and pitch are kept). Returns the same
    :class:`Localization` as :func:`~bim2rdt.localization.localize`; raises :class:`LocalizationError` with the
    reason. A :class:`ScanPoints` (what :func:`scan_points` made of a cloud) is used as it is.

    Args:
        cloud: Anything with ``.points`` (N,3) in the sensor frame, metres (NaN rows are no return), or a
            :class:`ScanPoints`.
        model: The BIM, loaded with geometry.
        prior_T_world_sensor: 4x4 sensor-to-world prior, metres.
        up: The world up measured by the sensor's IMU, a unit 3-vector.
        config: Localization's settings; None uses the defaults.

    Returns:
        The fix: ``pose`` (``T_world_sensor``, 4x4), covariance, information, free directions and residual.

    Raises:
        LocalizationError: A bad cloud or prior, too few returns in range, no permanent element in view, or a
            correction beyond the basin; the message gives the reason.
    """
    cfg = config or LocalizationConfig()
    prior, up_world = _rigid_prior(prior_T_world_sensor), _unit_up(up)
    scan = cloud if isinstance(cloud, ScanPoints) else scan_points(cloud, cfg)
    scene = OccludedMap.of(model)

    def fit(start: np.ndarray, icp: IcpConfig, coarse: bool) -> tuple[np.ndarray, int]:
        return _fit(scan, scene, start, start, up_world, icp, cfg, (2 if coarse else 1) * cfg.cloud_ray_deg)

    pose, near, moved, turned = _within_basin(fit, prior, up_world, cfg, "sensor")
    visible = scene.visible(pose, scan.directions, cfg.cloud_ray_deg, cfg.cloud_margin_deg, cfg.max_range * 1.2)
    return _judge(scan, scene, visible, pose, prior, up_world, near, moved, turned, cfg)


def scan_points(cloud, cfg: LocalizationConfig) -> ScanPoints:
    """The cloud's returns in [min_range, max_range], one per ``cloud_voxel`` cube (their mean), at most
    ``cloud_points`` of them (an even draw), with PCA normals; :class:`LocalizationError` on bad input."""
    points = getattr(cloud, "points", None)
    if points is None:
        raise LocalizationError(f"expected a cloud with .points (N, 3), got {type(cloud).__name__}")
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3:
        raise LocalizationError(f"cloud.points must be (N, 3) metres, got shape {points.shape}")
    points = points[np.all(np.isfinite(points), axis=1)]
    distance = np.linalg.norm(points, axis=1)
    points = points[(distance >= cfg.min_range) & (distance <= cfg.max_range)]
    if len(points) < cfg.min_points:
        raise LocalizationError(f"the cloud has {len(points)} returns in {cfg.min_range}-{cfg.max_range} m of the "
                                f"sensor, need {cfg.min_points}")
    thinned = voxel_means(points, cfg.cloud_voxel)
    if len(thinned) > cfg.cloud_points:
        thinned = thinned[np.random.default_rng(0).choice(len(thinned), cfg.cloud_points, replace=False)]
    return ScanPoints(thinned, pca_normals(thinned, cfg.cloud_normal_neighbours))


def voxel_means(points: np.ndarray, voxel: float) -> np.ndarray:
    """One point per occupied ``voxel`` cube (the mean of its points), (M, 3): a scan's density falls with range
    and a frame's is highest near the camera; the fix should weigh surfaces, not the sensor's sampling. No
    points, no cubes (a planned object in view that owns none of a frame's points)."""
    if len(points) == 0:
        return np.zeros((0, 3))
    cells = np.floor(points / voxel).astype(np.int64)
    cells -= cells.min(axis=0)
    size = cells.max(axis=0) + 1
    keys = (cells[:, 0] * size[1] + cells[:, 1]) * size[2] + cells[:, 2]  # one integer per cube: a 1-D unique
    _, inverse, counts = np.unique(keys, return_inverse=True, return_counts=True)
    sums = np.zeros((len(counts), 3))
    np.add.at(sums, inverse.reshape(-1), points)
    return sums / counts[:, None]


def pca_normals(points: np.ndarray, neighbours: int) -> np.ndarray:
    """Unit normals (N, 3) from each point's ``neighbours`` nearest (the smallest principal axis), turned towards
    the sensor at the origin; NaN where the neighbourhood is not a plane (its smallest spread is more than a
    third of the middle one: an edge, a corner, clutter)."""
    k = min(neighbours, len(points))
    _, index = cKDTree(points).query(points, k=k)
    local = points[index] - points[index].mean(axis=1, keepdims=True)
    values, vectors = np.linalg.eigh(np.einsum("nki,nkj->nij", local, local))
    normals = vectors[:, :, 0]
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
        """The model's map, built once per model object (the last few are kept)."""
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
        over the directions within ``margin_deg`` of the cloud's (``directions_sensor``, unit, sensor frame),
        within ``max_range`` m, on a permanent element (not an occluder), grazing hits dropped."""
        origin = T_world_sensor[:3, 3]
        directions = covered(sphere_directions(ray_deg), directions_sensor @ T_world_sensor[:3, :3].T, margin_deg)
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
        """How many rays ``ray_deg`` apart, over the directions of ``directions_sensor`` (unit, sensor frame), first
        hit each occluder (GlobalId -> rays) within ``max_range``: which of the model's objects the sensor could
        see from ``T_world_sensor``, each behind the walls and the other objects."""
        origin = T_world_sensor[:3, 3]
        directions = covered(sphere_directions(ray_deg), directions_sensor @ T_world_sensor[:3, :3].T, ray_deg)
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
    """Unit vectors (K, 3) spread evenly over the sphere about ``step_deg`` apart (a Fibonacci lattice)."""
    step = np.deg2rad(step_deg)
    count = max(16, int(round(4 * np.pi / step**2)))
    k = np.arange(count) + 0.5
    z = 1 - 2 * k / count
    azimuth = np.pi * (1 + 5**0.5) * k
    ring = np.sqrt(1 - z**2)
    return np.stack([ring * np.cos(azimuth), ring * np.sin(azimuth), z], axis=1)


def covered(directions: np.ndarray, seen: np.ndarray, margin_deg: float) -> np.ndarray:
    """The ``directions`` (unit) within ``margin_deg`` of any of ``seen`` (unit): where the sensor looked."""
    chord = 2 * np.sin(np.deg2rad(margin_deg) / 2)
    gap, _ = cKDTree(seen).query(directions, distance_upper_bound=chord)
    return directions[np.isfinite(gap)]


def _fit(scan: ScanPoints, scene: OccludedMap, view: np.ndarray, start: np.ndarray, up_world: np.ndarray,
         icp: IcpConfig, cfg: LocalizationConfig, ray_deg: float) -> tuple[np.ndarray, int]:
    """One yaw-only registration pass of the points placed by ``start`` against the surface visible from
    ``view`` (as :func:`bim2rdt.localization.fix._fit`): (T_world_sensor, points within the basin)."""
    visible = scene.visible(view, scan.directions, ray_deg, cfg.cloud_margin_deg, cfg.max_range * 1.2)
    placed = scan.points @ start[:3, :3].T + start[:3, 3]
    near = _within(placed, visible, cfg.max_correction)
    if len(visible.points) < 6 or near.sum() < cfg.min_points:
        raise LocalizationError(f"the cloud sees no permanent element: {int(near.sum())} of its {len(placed)} "
                                f"thinned points lie within {cfg.max_correction} m of a wall, column, slab, stair or "
                                f"door seen from the prior, need {cfg.min_points}")
    centre = np.eye(4)
    centre[:3, 3] = start[:3, 3]
    try:
        fit = register(visible.points - centre[:3, 3], visible.normals, placed[near], init=centre, up=up_world,
                       upright_bias=0.0, yaw_only=True, config=icp)
    except RegistrationError as error:
        raise LocalizationError(f"registration failed: {error}") from None
    return centre @ invert_poses(fit.pose) @ start, int(near.sum())


def _judge(scan: ScanPoints, scene: OccludedMap, visible: SurfaceSamples, pose: np.ndarray, prior: np.ndarray,
           up_world: np.ndarray, near: int, moved: float, turned: float, cfg: LocalizationConfig) -> Localization:
    """Inliers, residual and observability at the final pose (as ``localize`` judges a frame's fix)."""
    placed = scan.points @ pose[:3, :3].T + pose[:3, 3]
    inlier, along, model_normals, agree = _pairs(placed, scan.normals @ pose[:3, :3].T, visible, cfg)
    count = int(inlier.sum())
    if count < cfg.min_inliers or count < cfg.min_inlier_fraction * near:
        raise LocalizationError(f"the fix moved the sensor {moved:.2f} m and turned it {turned:.1f} deg from the "
                                f"prior, but only {count} of the {near} points near the map lie on it (need "
                                f"{cfg.min_inliers} and {cfg.min_inlier_fraction:.0%}): the prior is probably beyond "
                                "the basin, or the depth is warped; rejected")
    behind = behind_fraction(scan.points, pose, scene.permanent, cfg.behind_tolerance)
    if behind > cfg.max_behind_fraction:
        raise LocalizationError(f"the fix moved the sensor {moved:.2f} m and turned it {turned:.1f} deg from the "
                                f"prior, but from there {behind:.0%} of the points would lie behind walls, columns "
                                f"or slabs (at most {cfg.max_behind_fraction:.0%}): rejected")
    residual = float(np.sqrt(np.mean(along[inlier] ** 2)))
    used = inlier & agree
    if used.sum() < 6:
        used = inlier
    seen = _observability(placed[used], model_normals[used], pose[:3, 3], up_world, residual, cfg)
    return Localization(pose=pose, covariance=seen.covariance, inliers=count, degenerate=seen.degenerate_translations,
                        residual=residual, degenerate_yaw=bool(seen.degenerate_rotations), information=seen.information,
                        points=len(placed), near=near, moved=moved, turned_deg=turned, prior=prior)


def behind_fraction(points_sensor: np.ndarray, pose: np.ndarray, surfaces: PermanentMap, tolerance: float) -> float:
    """Fraction of the points farther than ``tolerance`` m beyond the first permanent surface on their ray from
    ``pose``'s position (a sensor cannot see through walls)."""
    distance = np.linalg.norm(points_sensor, axis=1)
    first = surfaces.first_hit(pose[:3, 3], (points_sensor / distance[:, None]) @ pose[:3, :3].T)
    return float(np.sum(distance > first + tolerance)) / max(len(points_sensor), 1)
