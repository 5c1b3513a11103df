"""Does the sensor's depth agree with the BIM's geometry? A miscalibrated depth camera bends space; no rigid pose
can undo that, and every object fitted in such a frame carries the bend.

Two tests on the permanent surfaces (walls, slabs, doors: what the localizer fixes on), both independent of
where objects stand:

- **angles**: the largest planes of the cloud (RANSAC in the sensor frame: no pose involved) are matched to
  the BIM surfaces they lie on (through the fix, else the prior), and the angle between every two of them is
  compared with the angle between their BIM surfaces. A rigid sensor keeps angles whatever its pose; office1's
  raw Kinect depth puts the back and left walls at 72-75 degrees where the BIM (and the corrected depth, within
  0.3 degrees) has 89;
- **residual**: the median distance of the points near a permanent surface to it at the fix. The corrected
  office1 frame reaches ~1.5-2 cm (Kinect noise at 2-5 m), the raw one 4.8 cm even at its best rigid fit.

Either beyond its threshold, and the sensor looks miscalibrated: its verdicts are not confident.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from bim2rdt.localization.cloud import OccludedMap, ScanPoints


@dataclass(frozen=True)
class DepthCheckConfig:
    """Thresholds of the miscalibration test (lengths in metres, angles in degrees)."""

    max_angle_error_deg: float = 3.0
    """Two permanent planes whose measured angle differs from the BIM's by more: the depth is warped. Plane
    normals from thousands of points are good to a fraction of a degree at Kinect noise (office1 corrected:
    <= 0.3 deg), construction puts walls square to ~1 deg; raw office1 is off by up to 17.7 deg."""
    max_median_residual: float = 0.035
    """Median distance of the points near permanent surfaces to them at the fix above this: the depth does not
    fit the BIM rigidly. Kinect v1 noise is ~1.4 mm x z^2 (3 cm at 4.7 m), its median |error| about two thirds
    of that: office1 corrected 1.5-2 cm, raw 4.8 cm at its best rigid fit."""
    near: float = 0.15
    """Points within this of a permanent surface count for the residual."""
    plane_distance: float = 0.04
    """RANSAC inlier distance of a plane."""
    min_plane_points: int = 150
    """Planes with fewer thinned points are too small to measure an angle on."""
    max_planes: int = 6
    match_deg: float = 25.0
    """A cloud plane lies on a BIM surface when most of its points' nearest BIM samples face its way within this."""
    iterations: int = 300


@dataclass(frozen=True)
class PlanePair:
    """Two matched planes: the BIM elements' GlobalIds, the measured and the BIM's angle between them (deg)."""

    first: str
    second: str
    measured_deg: float
    bim_deg: float

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
        return max((abs(p.error_deg) for p in self.pairs), default=None)

    def to_dict(self) -> dict:
        return {"miscalibrated": self.miscalibrated, "reason": self.reason, "median_residual": self.median_residual,
                "worst_angle_error_deg": self.worst_angle_deg,
                "plane_pairs": [{"first": p.first, "second": p.second, "measured_deg": round(p.measured_deg, 2),
                                 "bim_deg": round(p.bim_deg, 2)} for p in self.pairs]}


def check_depth(scan: ScanPoints, scene: OccludedMap, pose: np.ndarray, fixed: bool, max_range: float,
                config: DepthCheckConfig = DepthCheckConfig()) -> DepthCheck:
    """The miscalibration test of ``scan`` (sensor frame) against the permanent surfaces visible from ``pose``
    (the fix when ``fixed``, else the prior: then only the angle test runs)."""
    visible = scene.visible(pose, scan.directions, 0.5, 8.0, max_range)
    if len(visible.points) < 6:
        return DepthCheck(False, "")
    placed = scan.points @ pose[:3, :3].T + pose[:3, 3]
    tree = cKDTree(visible.points)
    pairs = _plane_pairs(scan, placed, tree, visible, scene, pose, 0.1 if fixed else 0.5, config)
    residual = _median_residual(placed, tree, visible, config.near) if fixed else None
    reasons = []
    worst = max(pairs, key=lambda p: abs(p.error_deg), default=None)
    if worst is not None and abs(worst.error_deg) > config.max_angle_error_deg:
        reasons.append(f"two permanent planes meet at {worst.measured_deg:.1f} deg where the BIM's meet at "
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
                 pose: np.ndarray, reach: float, config: DepthCheckConfig) -> list[PlanePair]:
    """Planes of the cloud (sensor frame) matched to BIM elements, each element once, compared two by two. Most of
    a plane's points must lie within ``reach`` of its element (10 cm from a fix: a cupboard's front 25 cm before
    the wall hidden behind it is not that wall; half a metre from a prior)."""
    matched: dict[str, tuple[np.ndarray, np.ndarray]] = {}  # element -> (measured normal (sensor), BIM normal)
    remaining = np.arange(len(scan.points))
    rng = np.random.default_rng(0)
    for _ in range(config.max_planes):
        plane = _ransac(scan.points[remaining], config, rng)
        if plane is None:
            break
        normal, members = plane
        members = remaining[members]
        remaining = np.setdiff1d(remaining, members)
        element, bim_normal = _bim_surface(placed[members], normal @ pose[:3, :3].T, tree, visible, scene, reach,
                                           config)
        if element is not None and element not in matched:
            matched[element] = (normal, bim_normal)
    names = list(matched)
    out = []
    for a in range(len(names)):
        for b in range(a + 1, len(names)):
            (n1, m1), (n2, m2) = matched[names[a]], matched[names[b]]
            out.append(PlanePair(names[a], names[b], _angle(n1, n2), _angle(m1, m2)))
    return out


def _ransac(points: np.ndarray, config: DepthCheckConfig, rng) -> tuple[np.ndarray, np.ndarray] | None:
    """The plane with the most points within ``plane_distance``, refined by least squares: (unit normal,
    indices of its points), or None when no plane has ``min_plane_points``."""
    if len(points) < config.min_plane_points:
        return None
    picks = rng.integers(0, len(points), size=(config.iterations, 3))
    a, b, c = points[picks[:, 0]], points[picks[:, 1]], points[picks[:, 2]]
    normals = np.cross(b - a, c - a)
    length = np.linalg.norm(normals, axis=1)
    good = length > 1e-9
    normals, a = normals[good] / length[good, None], a[good]
    counts = (np.abs((points[None, :, :] - a[:, None, :]) @ normals[..., None])[..., 0]
              < config.plane_distance).sum(axis=1)
    if len(counts) == 0 or counts.max() < config.min_plane_points:
        return None
    best = int(np.argmax(counts))
    members = np.flatnonzero(np.abs((points - a[best]) @ normals[best]) < config.plane_distance)
    centred = points[members] - points[members].mean(axis=0)
    normal = np.linalg.svd(centred, full_matrices=False)[2][-1]
    members = np.flatnonzero(np.abs((points - points[members].mean(axis=0)) @ normal) < config.plane_distance)
    return normal, members


def _bim_surface(placed: np.ndarray, normal_world: np.ndarray, tree: cKDTree, visible, scene: OccludedMap,
                 reach: float, config: DepthCheckConfig) -> tuple[str | None, np.ndarray | None]:
    """The permanent element most of a plane's points lie nearest (within half a metre), when its surface there
    faces the plane's way within ``match_deg``: (GlobalId, its unit normal), else (None, None)."""
    gap, index = tree.query(placed, distance_upper_bound=reach)
    found = np.isfinite(gap)
    if found.sum() < 0.5 * len(placed):
        return None, None
    owners = visible.owner[index[found]]
    owner = int(np.bincount(owners).argmax())
    normals = visible.normals[index[found]][owners == owner]
    bim = normals.mean(axis=0)
    bim /= np.linalg.norm(bim)
    if _angle(bim, normal_world, unsigned=True) > config.match_deg:
        return None, None
    return scene.permanent.element_ids[owner], bim


def _angle(a: np.ndarray, b: np.ndarray, unsigned: bool = True) -> float:
    """Angle between two plane normals in degrees, 0-90 (a plane's normal has no sign)."""
    cos = abs(float(np.dot(a, b))) / (np.linalg.norm(a) * np.linalg.norm(b))
    return float(np.rad2deg(np.arccos(min(1.0, cos))))
