"""Global localization on the BIM: where the sensor stands, from the data and the model alone (no prior).

1. gravity (the source's IMU up, else the floor plane's normal: :mod:`.gravity`) levels the points and the
   floor gives the height, so only x, y and yaw are left;
2. a coarse correlative search over every storey's free space (:mod:`.global_map`) and every heading
   ``yaw_step_deg`` apart: the wall-facing points, turned by the heading, are scored at every cell at once (one
   FFT correlation per heading) by how near they fall to a permanent surface, less a penalty for each sample
   of their rays that would cross a wall before the return (a sensor cannot see through walls);
3. the best separated peaks are refined by the 4-DoF fix (:func:`~bim2rdt.localization.localize_cloud`: the
   BIM ray cast from the candidate with the model's other bodies occluding, yaw-only ICP, its acceptance tests),
   first quickly (a thinner cloud, a wider basin: a peak is a guess, not a prior); when one place stands out
   it is fixed again in full, from where the quick fix stopped;
4. each refined candidate is scored on the cloud's sideways-facing points (the floor says nothing about where on
   it the sensor stands): the share on the first permanent surface their ray meets from the pose, less the share
   seen through one. When a second place scores within noise of the best (:func:`noise`), or the best cannot fix
   a direction, the view is ambiguous: :func:`choose` takes no pose, and says how many places fit.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np
from scipy import fft, ndimage

from bim2rdt.bim import BimModel
from bim2rdt.localization.cloud import OccludedMap, ScanPoints, localize_cloud, scan_points
from bim2rdt.localization.config import LocalizationConfig
from bim2rdt.localization.depth import depth_points
from bim2rdt.localization.errors import LocalizationError
from bim2rdt.localization.global_config import GlobalSearchConfig
from bim2rdt.localization.global_map import StoreyPlan, storey_plans
from bim2rdt.localization.gravity import CAMERA_UP, SCANNER_UP, Levelled, level
from bim2rdt.localization.planar import rz, wrap
from bim2rdt.perception import Frame


@dataclass(frozen=True)
class Candidate:
    """One place the sensor may stand. ``pose`` T_world_sensor (4, 4); ``score`` of the 4-DoF fix (the module's
    note, step 4; the coarse score when the fix refused it); ``covariance`` (6, 6)
    of the fix (None when refused); ``degenerate`` unit world directions the view cannot fix; ``refined`` whether
    the fix accepted it (else ``reason`` says why); ``coarse_score`` the search's; ``storey``; ``gravity`` where
    up came from (``given``, ``imu`` or ``floor``); ``seconds`` the whole search's time."""

    pose: np.ndarray
    score: float
    covariance: np.ndarray | None
    degenerate: list[np.ndarray]
    refined: bool
    coarse_score: float
    storey: str
    gravity: str
    reason: str | None = None
    inliers: int = 0
    residual: float | None = None
    seconds: float = 0.0
    extra: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        """The candidate as localization.json lists it.

        Returns:
            JSON-ready fields (pose rows, scores, storey, gravity, free directions, the fix's reason).
        """
        return {"pose": np.round(self.pose, 6).tolist(), "score": round(self.score, 4),
                "coarse_score": round(self.coarse_score, 4), "refined": self.refined, "storey": self.storey,
                "gravity": self.gravity, "degenerate": [np.round(d, 4).tolist() for d in self.degenerate],
                "inliers": self.inliers, "residual": None if self.residual is None else round(self.residual, 4),
                "reason": self.reason}


def find_pose(data: object, model: BimModel, up: np.ndarray | tuple[float, float, float] | None = None,
              config: GlobalSearchConfig | None = None, storey: str | None = None) -> list[Candidate]:
    """Find where the sensor that took ``data`` stands on ``model``, without a prior.

    Args:
        data: A :class:`~bim2rdt.perception.Frame` (its IMU ``up`` is used when ``up`` is None) or a cloud
            (anything with ``.points`` (N, 3), sensor frame, metres; NaN rows are no return).
        model: The BIM, loaded with geometry.
        up: Gravity up in the sensor frame (an IMU's); None takes the frame's IMU, else the floor plane.
        config: The search's settings; None uses the defaults.
        storey: A storey's name or GlobalId to search; None searches every storey.

    Returns:
        The candidates, best first (the fix-accepted ones by score, then the refused ones); :func:`choose` says
            whether the best is to be taken.

    Raises:
        LocalizationError: Bad data, no floor in view (the height is unknown) or nothing to search.
    """
    started = time.process_time()
    cfg = config or GlobalSearchConfig()
    scan, default_up, up, gravity = _prepared(data, up, cfg)
    levelled = level(scan, up, gravity, default_up, cfg.floor_cone_deg, cfg.min_floor_points)
    plan_points, walls = _plan_points(scan, levelled, cfg)
    if len(plan_points) < 10:
        raise LocalizationError(f"only {len(plan_points)} points face sideways {cfg.band[0]}-{cfg.band[1]} m above "
                                "the floor: no wall or column in view to search with")
    peaks = []
    for plan in storey_plans(model, storey, cfg.resolution, cfg.band, cfg.sigma, cfg.clearance):
        peaks += [(score, plan, xy, yaw) for score, xy, yaw in coarse_peaks(plan, plan_points, cfg)]
    peaks = _separated(sorted(peaks, key=lambda p: -p[0]), cfg)[: cfg.candidates]
    quick_scan, quick_cfg = _quick(scan, cfg)
    judge = _ViewScore(walls, OccludedMap.of(model), cfg)
    quick = _unique([_refine(quick_scan, model, levelled, peak, quick_cfg, judge) for peak in peaks], cfg)
    taken, _ = choose(quick, cfg)
    if taken is None:  # no place fits, or several do already: fixing them again in full would not make one
        candidates = quick
    else:
        candidates = _unique([_fixed(scan, model, taken, cfg.fix, judge)] + [c for c in quick if c is not taken], cfg)
    seconds = time.process_time() - started
    return [replace(c, seconds=seconds) for c in candidates]


def choose(candidates: list[Candidate], config: GlobalSearchConfig | None = None) -> tuple[Candidate | None, str]:
    """The candidate to take, or None with the reason.

    Args:
        candidates: :func:`find_pose`'s answer.
        config: The search's settings (its ``ambiguity_margin``); None uses the defaults.

    Returns:
        The best candidate and an empty reason when it is the only place that fits within noise and its view fixes
            every direction; else None and the reason (``"ambiguous: N places fit"``, or why no place fits).
    """
    cfg = config or GlobalSearchConfig()
    fits = [c for c in candidates if c.refined]
    if not fits:
        reasons = {c.reason for c in candidates if c.reason}
        return None, "no place on the BIM fits" + (f" (best candidate: {candidates[0].reason})" if reasons else "")
    best = fits[0]
    close = [c for c in fits if c.score >= best.score - noise(best.score, cfg)]
    if len(close) > 1:
        return None, f"ambiguous: {len(close)} places fit"
    if best.degenerate:
        return None, f"ambiguous: the view cannot fix {len(best.degenerate)} direction(s) (a single wall, a corridor)"
    return best, ""


def noise(score: float, cfg: GlobalSearchConfig) -> float:
    """How far below ``score`` another place still fits within noise: ``ambiguity_sigmas`` standard deviations
    of a share over the view's ``independent_points`` observations, at least ``ambiguity_margin``."""
    share = min(max(score, 0.0), 1.0)
    sigma = np.sqrt(share * (1 - share) / cfg.fix.independent_points)
    return float(max(cfg.ambiguity_margin, cfg.ambiguity_sigmas * sigma))


def coarse_peaks(plan: StoreyPlan, points_xy: np.ndarray, cfg: GlobalSearchConfig
                 ) -> list[tuple[float, np.ndarray, float]]:
    """The coarse search of one storey: (score, world (x, y), yaw rad) of the local maxima over cells and
    headings, best first, at most ``4 * candidates``.

    Args:
        plan: The storey's plan rasters.
        points_xy: Levelled plan points (N, 2) in the sensor's levelled frame, m.
        cfg: The search's settings.

    Returns:
        The peaks, best first.
    """
    yaws = np.deg2rad(np.arange(0.0, 360.0, cfg.yaw_step_deg))
    scores = correlate(plan, points_xy, yaws, cfg.through_weight)
    scores[:, ~plan.free] = -np.inf
    cells = max(3, int(round(cfg.peak_separation / plan.resolution)) | 1)
    neighbourhood = (3, cells, cells)
    local = scores == ndimage.maximum_filter(scores, size=neighbourhood, mode=("wrap", "nearest", "nearest"))
    k, rows, cols = np.nonzero(local & np.isfinite(scores))
    order = np.argsort(-scores[k, rows, cols])[: 4 * cfg.candidates]
    xy = plan.centre(rows[order], cols[order])
    return [(float(scores[k[o], rows[o], cols[o]]), xy[i], float(yaws[k[o]])) for i, o in enumerate(order)]


def correlate(plan: StoreyPlan, points_xy: np.ndarray, yaws: np.ndarray, through_weight: float) -> np.ndarray:
    """Score (len(yaws), rows, cols) of the sensor at every cell and heading: the mean surface likelihood at its
    points less ``through_weight`` x the ray samples per point that fall in solid cells (FFT correlation)."""
    r = plan.resolution
    reach = int(np.ceil(np.linalg.norm(points_xy, axis=1).max() / r)) + 2
    rows, cols = plan.likelihood.shape
    shape = (fft.next_fast_len(rows + 2 * reach), fft.next_fast_len(cols + 2 * reach))
    hit_map = fft.rfft2(_padded(plan.likelihood, reach, shape))
    solid_map = fft.rfft2(_padded(plan.solid.astype(np.float64), reach, shape))
    rays = _ray_samples(points_xy)
    scores = np.empty((len(yaws), rows, cols))
    for k, yaw in enumerate(yaws):
        hit = _kernel(points_xy, yaw, r, shape, 1.0 / len(points_xy))
        through = _kernel(rays, yaw, r, shape, through_weight / len(points_xy))
        full = fft.irfft2(hit_map * np.conj(hit) - solid_map * np.conj(through), s=shape)
        scores[k] = full[reach: reach + rows, reach: reach + cols]
    return scores


def _padded(image: np.ndarray, reach: int, shape: tuple[int, int]) -> np.ndarray:
    out = np.zeros(shape)
    out[reach: reach + image.shape[0], reach: reach + image.shape[1]] = image
    return out


def _kernel(points_xy: np.ndarray, yaw: float, resolution: float, shape: tuple[int, int], weight: float
            ) -> np.ndarray:
    """rfft2 of the points turned by ``yaw``, as cell offsets wrapped into ``shape`` (circular correlation)."""
    c, s = np.cos(yaw), np.sin(yaw)
    x = np.rint((c * points_xy[:, 0] - s * points_xy[:, 1]) / resolution).astype(np.int64) % shape[1]
    y = np.rint((s * points_xy[:, 0] + c * points_xy[:, 1]) / resolution).astype(np.int64) % shape[0]
    image = np.bincount(y * shape[1] + x, minlength=shape[0] * shape[1]).astype(np.float64) * weight
    return fft.rfft2(image.reshape(shape))


def _ray_samples(points_xy: np.ndarray, step: float = 0.15, start: float = 0.3, short: float = 0.3) -> np.ndarray:
    """Plan samples along each point's ray from the sensor, ``step`` m apart from ``start`` m to ``short`` m
    before the return: where the sensor saw through, so no wall may stand."""
    distance = np.linalg.norm(points_xy, axis=1)
    unit = points_xy / np.maximum(distance, 1e-9)[:, None]
    counts = np.maximum(0, np.floor((distance - short - start) / step).astype(int) + 1)
    owner = np.repeat(np.arange(len(points_xy)), counts)
    along = start + step * (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts))
    return unit[owner] * along[:, None]


def _prepared(data: object, up, cfg: GlobalSearchConfig) -> tuple[ScanPoints, np.ndarray, np.ndarray | None, str]:
    """(thinned points with normals, the sensor's usual up, the up to use or None, where it came from)."""
    if isinstance(data, Frame):
        points = depth_points(data, 2, cfg.fix.min_range, cfg.fix.max_range)
        default_up, imu = CAMERA_UP, data.up
    else:
        points, default_up, imu = getattr(data, "points", data), SCANNER_UP, getattr(data, "up", None)
    scan = scan_points(np.asarray(points, dtype=np.float64), cfg.fix)
    if up is not None:
        return scan, default_up, np.asarray(up, dtype=np.float64), "given"
    if imu is not None:
        return scan, default_up, np.asarray(imu, dtype=np.float64), "imu"
    return scan, default_up, None, "floor"


def _plan_points(scan: ScanPoints, levelled: Levelled, cfg: GlobalSearchConfig) -> tuple[np.ndarray, np.ndarray]:
    """(the levelled (x, y) of the points that face sideways within the band, at most ``max_plan_points``;
    every sideways point in the sensor frame, at most ``max_plan_points``: what candidates are judged on)."""
    points = scan.points @ levelled.R_level_sensor.T
    normals = scan.normals @ levelled.R_level_sensor.T
    height = points[:, 2] + levelled.height
    sideways = np.isfinite(normals[:, 2]) & (np.abs(np.nan_to_num(normals[:, 2], nan=1.0)) < cfg.wall_normal_z)
    keep = sideways & (height >= cfg.band[0]) & (height <= cfg.band[1])
    xy = _thinned(points[keep, :2], cfg.resolution / 2)
    rng = np.random.default_rng(0)
    if len(xy) > cfg.max_plan_points:
        xy = xy[rng.choice(len(xy), cfg.max_plan_points, replace=False)]
    walls = scan.points[sideways]
    if len(walls) > cfg.max_plan_points:
        walls = walls[rng.choice(len(walls), cfg.max_plan_points, replace=False)]
    return xy, walls


class _ViewScore:
    """A candidate's score: of the sideways-facing points (walls, columns, furniture fronts; the floor says
    nothing about where on it the sensor stands), the share that lies on the first permanent surface their ray
    meets from the pose, less the share that lies behind it (seen through a wall). Points whose ray first meets
    another body of the model (furniture) count neither way."""

    def __init__(self, walls: np.ndarray, scene: OccludedMap, cfg: GlobalSearchConfig) -> None:
        self.range = np.linalg.norm(walls, axis=1)
        self.unit = walls / np.maximum(self.range, 1e-9)[:, None]
        self.scene, self.on = scene, 2 * cfg.fix.inlier_distance
        self.behind = cfg.fix.behind_tolerance

    def __call__(self, pose: np.ndarray) -> float:
        if len(self.range) == 0:
            return 0.0
        mesh = self.scene.mesh
        directions = self.unit @ pose[:3, :3].T
        origin = pose[:3, 3]
        face = mesh.ray.intersects_first(np.broadcast_to(origin, directions.shape), directions)
        t = np.full(len(face), np.inf)
        hit = face >= 0
        normals = mesh.face_normals[face[hit]]
        corner = mesh.vertices[mesh.faces[face[hit], 0]]
        with np.errstate(divide="ignore", invalid="ignore"):
            t[hit] = np.einsum("ni,ni->n", normals, corner - origin) / np.einsum("ni,ni->n", normals, directions[hit])
        owner = np.full(len(face), -1)
        owner[hit] = self.scene.face_owner[face[hit]]
        near = np.abs(t - self.range) < self.on
        furniture = hit & (owner < 0) & (self.range > t - self.on)
        on = hit & (owner >= 0) & near
        behind = hit & (owner >= 0) & (self.range > t + self.behind)
        counted = max(int((~furniture).sum()), 1)
        return float((on.sum() - behind.sum()) / counted)


def _thinned(xy: np.ndarray, cell: float) -> np.ndarray:
    if len(xy) == 0:
        return xy
    _, first = np.unique(np.floor(xy / cell).astype(np.int64), axis=0, return_index=True)
    return xy[np.sort(first)]


def _separated(peaks: list, cfg: GlobalSearchConfig) -> list:
    """Greedy: each peak kept unless a better kept one on its storey is within the separation in place and
    heading."""
    kept = []
    for peak in peaks:
        _, plan, xy, yaw = peak
        if not any(p[1] is plan and np.linalg.norm(p[2] - xy) < cfg.peak_separation
                   and abs(wrap(p[3] - yaw)) < np.deg2rad(cfg.peak_separation_deg) for p in kept):
            kept.append(peak)
    return kept


def _quick(scan: ScanPoints, cfg: GlobalSearchConfig) -> tuple[ScanPoints, LocalizationConfig]:
    """The thinner cloud, ray cast and wider basin every coarse peak is first fixed with (``quick_points``,
    ``quick_ray_deg``, ``quick_basin``: a coarse peak is a guess, not a prior); the contenders are then fixed
    again with the full cloud and settings."""
    quick = cfg.fix.model_copy(update={"cloud_ray_deg": max(cfg.fix.cloud_ray_deg, cfg.quick_ray_deg),
                                       "min_points": min(cfg.fix.min_points, cfg.quick_points // 8),
                                       "min_inliers": min(cfg.fix.min_inliers, cfg.quick_points // 10),
                                       "max_correction": cfg.quick_basin * cfg.fix.max_correction,
                                       "max_correction_deg": cfg.quick_basin * cfg.fix.max_correction_deg})
    if len(scan.points) <= cfg.quick_points:
        return scan, quick
    pick = np.random.default_rng(0).choice(len(scan.points), cfg.quick_points, replace=False)
    return ScanPoints(scan.points[pick], scan.normals[pick]), quick


def _refine(scan: ScanPoints, model: BimModel, levelled: Levelled, peak, fix_cfg: LocalizationConfig,
            judge: _ViewScore) -> Candidate:
    """The coarse peak as a pose, fixed by the 4-DoF fix; refused peaks keep their coarse pose and score."""
    coarse, plan, xy, yaw = peak
    start = np.eye(4)
    start[:3, :3] = rz(yaw) @ levelled.R_level_sensor
    start[:3, 3] = (xy[0], xy[1], plan.floor_z + levelled.height)
    candidate = Candidate(start, coarse, None, [], False, coarse_score=coarse, storey=plan.name,
                          gravity=levelled.gravity)
    return _fixed(scan, model, candidate, fix_cfg, judge)


def _fixed(scan: ScanPoints, model: BimModel, candidate: Candidate, fix_cfg: LocalizationConfig,
           judge: _ViewScore) -> Candidate:
    """``candidate`` fixed by :func:`localize_cloud` from its pose and scored by ``judge``, or refused with the
    reason (keeping its pose and score)."""
    try:
        fix = localize_cloud(scan, model, candidate.pose, (0.0, 0.0, 1.0), fix_cfg)
    except LocalizationError as error:
        return replace(candidate, refined=False, reason=str(error), covariance=None, degenerate=[])
    return replace(candidate, pose=fix.pose, score=judge(fix.pose), covariance=fix.covariance,
                   degenerate=list(fix.degenerate), refined=True, reason=None, inliers=fix.inliers,
                   residual=fix.residual)


def _unique(candidates: list[Candidate], cfg: GlobalSearchConfig) -> list[Candidate]:
    """Accepted candidates by score, then refused ones by coarse score; of those that converged to one pose
    (within ``same_place`` and ``same_place_deg``), the best only."""
    ordered = sorted(candidates, key=lambda c: (not c.refined, -c.score))
    kept: list[Candidate] = []
    for c in ordered:
        if not any(_same(c.pose, k.pose, cfg) for k in kept if k.refined == c.refined):
            kept.append(c)
    return kept


def _same(a: np.ndarray, b: np.ndarray, cfg: GlobalSearchConfig) -> bool:
    relative = a[:3, :3] @ b[:3, :3].T
    turn = np.arctan2(relative[1, 0], relative[0, 0])
    return bool(np.linalg.norm(a[:3, 3] - b[:3, 3]) < cfg.same_place and abs(turn) < np.deg2rad(cfg.same_place_deg))
