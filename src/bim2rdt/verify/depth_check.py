"""Does the sensor's depth agree with the BIM's geometry? A miscalibrated depth camera bends space; no rigid pose
can undo that, and every object fitted in such a frame carries the bend.

Two tests on the permanent surfaces at the fix:

- **angles**: the points near each planar BIM face in view (:mod:`.faces`: coplanar triangles of walls, slabs,
  columns with enough area; never a stair, a ramp, a railing, a curved wall or a door) get a least-squares plane
  in the sensor frame, and the angle between every two such planes is compared with the angle between their BIM
  faces. A rigid sensor
  keeps angles whatever its pose; office1's raw Kinect depth puts its floor and left wall at 86.5 degrees at its
  best rigid fit (the truth file's raw plane fits: 72-75 degrees between walls), the corrected depth within 0.9
  degrees of the BIM;
- **residual**: the median distance of the points within 15 cm of a permanent surface to it. The corrected
  office1 frame: 2.9 cm (Kinect noise at 2-5 m); the raw one 3.9-4.1 cm at its best rigid fit.

Either beyond its threshold, and the sensor looks miscalibrated: its verdicts are not confident.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pydantic import BaseModel, ConfigDict
from scipy.spatial import cKDTree

from bim2rdt.localization import OccludedMap, ScanPoints
from bim2rdt.verify.faces import PlanarFaces, PlanarFacesConfig


class DepthCheckConfig(BaseModel):
    """Thresholds of the miscalibration test (lengths in metres, angles in degrees)."""

    model_config = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)

    max_angle_error_deg: float = 2.5
    """Two wall or slab faces whose measured angle differs from the BIM's by more: the depth is bent. office1
    corrected: <= 0.9 deg over six priors (the left wall is 89.1 deg to the back wall in the BIM, 89.8 measured);
    raw at its best rigid fit: 3.4-3.6 deg (floor to left wall 86.5). Walls are built square to ~1 deg."""
    max_median_residual: float = 0.035
    """Median distance of the points within ``near`` of a permanent surface to it at the fix above this: the depth
    does not fit the BIM rigidly. Kinect v1 noise is ~1.4 mm x z^2 (3 cm at 4.7 m), its median |error| about
    two thirds of that: office1 corrected 2.9 cm here (points to 8 m, within 15 cm), raw 3.9-4.1 cm at its
    best rigid fit."""
    near: float = 0.15
    """Points within this of a permanent surface count for the residual."""
    plane_distance: float = 0.06
    """A face's plane is refitted on its points within this of the first fit."""
    min_plane_points: int = 150
    """Faces with fewer thinned points are too small to measure an angle on."""
    reach: float = 0.1
    """A point belongs to the wall or slab face whose visible sample lies within this at the fix."""


@dataclass(frozen=True)
class PlanePair:
    """Two matched planes: the BIM elements' GlobalIds, the measured and the BIM's angle between them (deg), and
    each face's BIM normal (world, unit) and number of measured points."""

    first: str
    second: str
    measured_deg: float
    bim_deg: float
    first_normal: tuple[float, float, float] = (0.0, 0.0, 0.0)
    second_normal: tuple[float, float, float] = (0.0, 0.0, 0.0)
    first_points: int = 0
    second_points: int = 0

    @property
    def error_deg(self) -> float:
        return self.measured_deg - self.bim_deg


@dataclass(frozen=True)
class DepthCheck:
    """The verdict: ``miscalibrated``, ``reason`` (one line, empty when fine), the plane pairs compared and the
    median residual (m, None without a fix)."""

    miscalibrated: bool
    reason: str
    pairs: list[PlanePair] = field(default_factory=list)
    median_residual: float | None = None

    @property
    def worst_angle_deg(self) -> float | None:
        """The largest angle error of the compared plane pairs, degrees; None without pairs."""
        return max((abs(p.error_deg) for p in self.pairs), default=None)

    def to_dict(self) -> dict:
        """The verdict as JSON-ready data.

        Returns:
            miscalibrated, reason, median_residual (metres), worst_angle_error_deg and the plane pairs (degrees).
        """
        return {"miscalibrated": self.miscalibrated, "reason": self.reason, "median_residual": self.median_residual,
                "worst_angle_error_deg": self.worst_angle_deg,
                "plane_pairs": [{"first": p.first, "second": p.second, "measured_deg": round(p.measured_deg, 2),
                                 "bim_deg": round(p.bim_deg, 2),
                                 "first_face": {"normal": [round(c, 3) for c in p.first_normal],
                                                "points": p.first_points},
                                 "second_face": {"normal": [round(c, 3) for c in p.second_normal],
                                                 "points": p.second_points}} for p in self.pairs]}


def check_depth(scan: ScanPoints, scene: OccludedMap, pose: np.ndarray, max_range: float,
                config: DepthCheckConfig = DepthCheckConfig(),
                faces: PlanarFacesConfig = PlanarFacesConfig()) -> DepthCheck:
    """The miscalibration test of ``scan`` (sensor frame) against the permanent surfaces visible from ``pose``
    (the sensor's best rigid fit on them).

    Args:
        scan: The scan's points and normals in the sensor frame, metres.
        scene: The model's permanent surfaces with their occlusion.
        pose: ``T_world_sensor`` (4x4, metres), the sensor's best rigid fit.
        max_range: Surfaces farther from the sensor than this are not compared, metres.
        config: The angle and residual limits.
        faces: Which BIM faces count as planes (:mod:`.faces`).

    Returns:
        The verdict: miscalibrated or not, the one-line reason, the plane pairs and the median residual.
    """
    visible = scene.visible(pose, scan.directions, 0.5, 8.0, max_range)
    if len(visible.points) < 6:
        return DepthCheck(False, "")
    placed = scan.points @ pose[:3, :3].T + pose[:3, 3]
    tree = cKDTree(visible.points)
    pairs = _plane_pairs(scan, placed, tree, visible, scene, pose, config, faces)
    residual = _median_residual(placed, tree, visible, config.near)
    reasons = []
    worst = max(pairs, key=lambda p: abs(p.error_deg), default=None)
    if worst is not None and abs(worst.error_deg) > config.max_angle_error_deg:
        reasons.append(f"two wall or slab faces meet at {worst.measured_deg:.1f} deg where the BIM's meet at "
                       f"{worst.bim_deg:.1f} (more than {config.max_angle_error_deg:g} deg off)")
    if residual is not None and residual > config.max_median_residual:
        reasons.append(f"points lie a median {100 * residual:.1f} cm from the walls and slabs at the best fit "
                       f"(more than {100 * config.max_median_residual:.1f} cm)")
    reason = ("the depth looks miscalibrated: " + "; ".join(reasons)) if reasons else ""
    return DepthCheck(bool(reasons), reason, pairs, residual)


def _median_residual(placed: np.ndarray, tree: cKDTree, visible, near: float) -> float | None:
    gap, index = tree.query(placed, distance_upper_bound=near)
    found = np.isfinite(gap)
    if found.sum() < 50:
        return None
    along = np.abs(np.einsum("ni,ni->n", visible.normals[index[found]], placed[found] - visible.points[index[found]]))
    return float(np.median(along))


def _plane_pairs(scan: ScanPoints, placed: np.ndarray, tree: cKDTree, visible, scene: OccludedMap,
                 pose: np.ndarray, config: DepthCheckConfig, rules: PlanarFacesConfig) -> list[PlanePair]:
    """The cloud segmented by the BIM's planar faces at the fix: each point goes to the visible face sample
    nearest it within ``reach``, when that sample lies on a planar face (:class:`~.faces.PlanarFaces`), the point
    itself lies within ``reach`` of that face's plane, and its own normal (where flat) agrees; a plane is fitted
    to each face's points in the SENSOR frame (least squares, trimmed), and the angles between the fitted planes
    are compared with the angles between their BIM faces. Least squares over a whole face averages a far wall's
    depth steps (7 cm at 5 m on a Kinect); RANSAC planes ran through them (8 degrees off a wall the corrected
    depth has square)."""
    faces = _faces(scene, rules)
    sample_face = faces.label(visible.points, visible.normals, visible.owner, rules.on_face)
    gap, index = tree.query(placed, distance_upper_bound=config.reach)
    found = np.flatnonzero(np.isfinite(gap))
    face = sample_face[index[found]]
    found, face = found[face >= 0], face[face >= 0]
    near = np.abs(np.einsum("ni,ni->n", placed[found], faces.normal[face]) - faces.offset[face]) <= config.reach
    found, face = found[near], face[near]
    own = scan.normals[found] @ pose[:3, :3].T
    flat = np.all(np.isfinite(own), axis=1)
    agree = ~flat | (np.abs(np.einsum("ni,ni->n", np.nan_to_num(own), faces.normal[face]))
                     >= np.cos(np.deg2rad(30.0)))
    found, face = found[agree], face[agree]
    measured = []
    for k in np.unique(face):
        members = found[face == k]
        if len(members) >= config.min_plane_points:
            measured.append((scene.permanent.element_ids[int(faces.owner[k])],
                             _plane_normal(scan.points[members], config.plane_distance), faces.normal[k],
                             len(members)))
    return [PlanePair(a[0], b[0], _angle(a[1], b[1]), _angle(a[2], b[2]), tuple(map(float, a[2])),
                      tuple(map(float, b[2])), a[3], b[3])
            for i, a in enumerate(measured) for b in measured[i + 1:]]


_FACES: dict[int, tuple[object, PlanarFacesConfig, PlanarFaces]] = {}


def _faces(scene: OccludedMap, rules: PlanarFacesConfig) -> PlanarFaces:
    """The planar faces of ``scene``'s permanent map, computed once per map and rules (the last few kept)."""
    permanent = scene.permanent
    cached = _FACES.get(id(permanent))
    if cached is None or cached[0] is not permanent or cached[1] != rules:
        cached = (permanent, rules, PlanarFaces.of(permanent.mesh, np.asarray(permanent.face_owner),
                                                   permanent.element_classes, rules))
        _FACES[id(permanent)] = cached
        while len(_FACES) > 4:
            _FACES.pop(next(iter(_FACES)))
    return cached[2]


def _plane_normal(points: np.ndarray, distance: float) -> np.ndarray:
    """Unit normal of the least-squares plane of ``points``, refitted on those within ``distance`` of it."""
    centre = points.mean(axis=0)
    normal = np.linalg.svd(points - centre, full_matrices=False)[2][-1]
    keep = np.abs((points - centre) @ normal) < distance
    if keep.sum() >= 3:
        centre = points[keep].mean(axis=0)
        normal = np.linalg.svd(points[keep] - centre, full_matrices=False)[2][-1]
    return normal


def _angle(a: np.ndarray, b: np.ndarray, unsigned: bool = True) -> float:
    """Angle between two plane normals in degrees, 0-90 (a plane's normal has no sign)."""
    cos = abs(float(np.dot(a, b))) / (np.linalg.norm(a) * np.linalg.norm(b))
    return float(np.rad2deg(np.arccos(min(1.0, cos))))
