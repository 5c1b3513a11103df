"""Global localization on the BIM: where the sensor stands, from the data and the model alone (no prior).

1. gravity (the source's IMU up, else the floor plane's normal: :mod:`.gravity`) levels the points and the
   floor gives the height, so only x, y and yaw are left. A cloud with no IMU (a scan in unknown axes) whose
   floor gives no pose has the floors along its other axes searched too (:func:`.gravity.other_floors`): a wall
   a metre or two away can pass for a floor, and the BIM tells them apart;
2. a coarse correlative search over every storey's free space (:mod:`.global_map`) and every heading
   ``yaw_step_deg`` apart: the wall-facing points, turned by the heading, are scored at every cell at once (one
   FFT correlation per heading) by how near they fall to a permanent surface, less a penalty for each 10 cm of
   their rays that would cross the cells inside a wall before the return (a sensor cannot see through walls);
   the best separated peaks are polished to a quarter cell and a sixth of a heading step (:func:`polish`);
3. each peak is screened by the whole view's likelihood at its coarse pose (:mod:`.view_score`, loose
   tolerances): every point of the cloud on the first surface its ray meets from the pose, seen through one,
   or short of it in free space. Best screen first, they are refined by the 4-DoF fix
   (:func:`~bim2rdt.localization.localize_cloud`: the BIM ray cast from the candidate with the model's other
   bodies occluding, yaw-only ICP, its acceptance tests), quickly (a thinner cloud, a wider basin: a peak is a
   guess, not a prior); a peak screened too far below the best fix to tie with it is not fixed, and at most
   ``candidates`` are. When one place stands out it is fixed again in full, from where the quick fix stopped;
4. each refined candidate is scored by that likelihood with the fix's tolerances; fixes of one place (within
   their covariance, or apart along a direction neither view fixes) are merged. When a second place scores
   within noise of the best (:func:`noise`; a place left unfixed whose screen does counts too), or the best
   cannot fix a direction, the view is ambiguous: :func:`choose` takes no pose, and says how many places fit.
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
from bim2rdt.localization.gravity import CAMERA_UP, SCANNER_UP, Levelled, level, other_floors
from bim2rdt.localization.pieces import free_standing
from bim2rdt.localization.planar import rz, wrap
from bim2rdt.localization.view_score import ViewScore
from bim2rdt.perception import Frame


@dataclass(frozen=True)
class Candidate:
    """One place the sensor may stand. ``pose`` T_world_sensor (4, 4); ``score`` the view's likelihood at the 4-DoF
    fix (the module's note, step 4; at the coarse pose, loosely, when it was not fixed or the fix refused it:
    ``extra["screen_score"]``; ``extra["unchecked"]`` when left unfixed for the fixes' budget); ``covariance`` (6, 6)
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
            JSON-ready fields (pose rows, scores, storey, gravity, free directions, the fix's reason, the screen's
                score at the coarse pose, whether it was left unfixed for the fixes' budget).
        """
        return {"pose": np.round(self.pose, 6).tolist(), "score": round(self.score, 4),
                "coarse_score": round(self.coarse_score, 4), "refined": self.refined, "storey": self.storey,
                "gravity": self.gravity, "degenerate": [np.round(d, 4).tolist() for d in self.degenerate],
                "inliers": self.inliers, "residual": None if self.residual is None else round(self.residual, 4),
                "reason": self.reason, "screen_score": self.extra.get("screen_score"),
                "unchecked": bool(self.extra.get("unchecked", False))}


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
    scan, default_up, up, gravity = prepared(data, up, cfg)
    levelled = level(scan, up, gravity, default_up, cfg.floor_cone_deg, cfg.min_floor_points)
    plan_points, view, things = _plan_points(scan, levelled, cfg)
    judge, screen = view_scores(view, things, OccludedMap.of(model), cfg)
    search = _LevelSearch(scan, model, storey, cfg, judge, screen)
    first_error: LocalizationError | None = None
    try:
        quick = search(levelled, plan_points)
    except LocalizationError as error:
        quick, first_error = [], error
    if up is None and not isinstance(data, Frame) and choose(quick, cfg)[0] is None:
        quick = _other_floors_searched(search, scan, levelled, quick, cfg)
    if first_error is not None and not quick:
        raise LocalizationError(str(first_error)) from first_error
    taken, _ = choose(quick, cfg)
    if taken is None:  # no place fits, or several do already: fixing them again in full would not make one
        candidates = quick
    else:
        full = fixed_candidate(scan, model, taken, cfg.fix, judge)
        candidates = _unique([full] + [c for c in quick if c is not taken], cfg)
    seconds = time.process_time() - started
    return [replace(c, seconds=seconds) for c in candidates]


@dataclass(frozen=True)
class _LevelSearch:
    """Steps 2-3 of the module's note for one levelling of the cloud: the coarse search over every storey, then the
    peaks screened and quickly fixed, judged on the whole view (the same ``judge`` for every levelling, so their
    candidates' scores compare)."""

    scan: ScanPoints
    model: BimModel
    storey: str | None
    cfg: GlobalSearchConfig
    judge: ViewScore
    screen: ViewScore

    def __call__(self, levelled: Levelled, plan_points: np.ndarray) -> list[Candidate]:
        cfg = self.cfg
        if len(plan_points) < 10:
            raise LocalizationError(f"only {len(plan_points)} points face sideways {cfg.band[0]}-{cfg.band[1]} m "
                                    "above the floor: no wall or column in view to search with")
        peaks = []
        for plan in storey_plans(self.model, self.storey, cfg.resolution, cfg.band, cfg.sigma, cfg.clearance):
            peaks += [(score, plan, xy, yaw) for score, xy, yaw in coarse_peaks(plan, plan_points, cfg)]
        peaks = _separated(sorted(peaks, key=lambda p: -p[0]), cfg)[: cfg.screened]
        peaks = [(score, plan, *polish(plan, plan_points, xy, yaw, cfg)) for score, plan, xy, yaw in peaks]
        return _unique(_refined_peaks(self.scan, self.model, levelled, peaks, cfg, self.judge, self.screen), cfg)


def _other_floors_searched(search: _LevelSearch, scan: ScanPoints, taken: Levelled, quick: list[Candidate],
                           cfg: GlobalSearchConfig) -> list[Candidate]:
    """A cloud with no IMU whose first floor gave no pose (a scan written y-up, or in a camera's axes, can have a
    wall within 0.1-3 m that passes for a floor): every other axis's floor is searched too, and all candidates
    compete on the same view (a wrong floor's places score far below the right one's; a tie stays ambiguous), and
    on the same judge: its free-standing things are those found above the first floor."""
    for other in other_floors(scan, taken, cfg.floor_cone_deg, cfg.min_floor_points):
        try:
            quick = _unique(quick + search(other, _plan_xy(scan, other, cfg, np.random.default_rng(0))), cfg)
        except LocalizationError:
            continue
    return quick


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
    close = [c for c in candidates if (c.refined or c.extra.get("unchecked"))
             and c.score >= best.score - noise(best.score, cfg)]
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


def polish(plan: StoreyPlan, points_xy: np.ndarray, xy: np.ndarray, yaw: float, cfg: GlobalSearchConfig
           ) -> tuple[np.ndarray, float]:
    """A coarse peak moved to the best of the poses around it, a quarter cell and a sixth of a heading step apart
    (within half a cell and half a step), by the mean surface likelihood at its points (read between cells):
    the fix then starts a few centimetres and a fraction of a degree off, not a cell and a step.

    Args:
        plan: The storey's plan rasters.
        points_xy: Levelled plan points (N, 2) in the sensor's levelled frame, m.
        xy: The peak's world (x, y), m.
        yaw: Its heading, rad.
        cfg: The search's settings.

    Returns:
        The polished (x, y) and heading.
    """
    step = np.deg2rad(cfg.yaw_step_deg)
    yaws = yaw + np.linspace(-step / 2, step / 2, 7)
    shifts = np.linspace(-plan.resolution / 2, plan.resolution / 2, 5)
    dx, dy = (g.ravel() for g in np.meshgrid(shifts, shifts))
    best = (-np.inf, xy, yaw)
    for candidate in yaws:
        c, s = np.cos(candidate), np.sin(candidate)
        turned = points_xy @ np.array([[c, s], [-s, c]]) + xy
        cells = (turned - plan.origin) / plan.resolution - 0.5
        rows = cells[None, :, 1] + dy[:, None] / plan.resolution
        cols = cells[None, :, 0] + dx[:, None] / plan.resolution
        values = ndimage.map_coordinates(plan.likelihood, [rows.ravel(), cols.ravel()], order=1, mode="nearest")
        means = values.reshape(len(dx), -1).mean(axis=1)
        k = int(np.argmax(means))
        if means[k] > best[0]:
            best = (means[k], xy + np.array([dx[k], dy[k]]), float(candidate))
    return best[1], best[2]


def correlate(plan: StoreyPlan, points_xy: np.ndarray, yaws: np.ndarray, through_weight: float) -> np.ndarray:
    """Score (len(yaws), rows, cols) of the sensor at every cell and heading: the mean surface likelihood at its
    points less ``through_weight`` per 10 cm of their rays that fall in solid cells, per point (FFT
    correlation)."""
    r = plan.resolution
    reach = int(np.ceil(np.linalg.norm(points_xy, axis=1).max() / r)) + 2
    rows, cols = plan.likelihood.shape
    shape = (fft.next_fast_len(rows + 2 * reach), fft.next_fast_len(cols + 2 * reach))
    hit_map = fft.rfft2(_padded(plan.likelihood, reach, shape))
    solid_map = fft.rfft2(_padded(plan.solid.astype(np.float64), reach, shape))
    rays = _ray_samples(points_xy)
    per_sample = through_weight * RAY_STEP / 0.1
    scores = np.empty((len(yaws), rows, cols))
    for k, yaw in enumerate(yaws):
        hit = _kernel(points_xy, yaw, r, shape, 1.0 / len(points_xy))
        through = _kernel(rays, yaw, r, shape, per_sample / len(points_xy))
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


RAY_STEP = 0.05
"""Spacing of the samples along a sensor ray in the coarse search's occlusion penalty, m: half a plan cell, so a
ray cannot step over the cells inside a 15 cm wall."""


def _ray_samples(points_xy: np.ndarray, step: float = RAY_STEP, start: float = 0.3, short: float = 0.25
                 ) -> np.ndarray:
    """Plan samples along each point's ray from the sensor, ``step`` m apart from ``start`` m to ``short`` m
    before the return: where the sensor saw through, so no wall may stand."""
    distance = np.linalg.norm(points_xy, axis=1)
    unit = points_xy / np.maximum(distance, 1e-9)[:, None]
    counts = np.maximum(0, np.floor((distance - short - start) / step).astype(int) + 1)
    owner = np.repeat(np.arange(len(points_xy)), counts)
    along = start + step * (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts))
    return unit[owner] * along[:, None]


def prepared(data: object, up: np.ndarray | tuple[float, float, float] | None, cfg: GlobalSearchConfig
             ) -> tuple[ScanPoints, np.ndarray, np.ndarray | None, str]:
    """A frame or cloud as the search and the sweep read it.

    Args:
        data: A :class:`~bim2rdt.perception.Frame` or a cloud (``.points`` (N, 3), sensor frame, m).
        up: Gravity up in the sensor frame (an IMU's); None takes the frame's IMU, else none is known.
        cfg: The search's settings (its fix's ranges and thinning).

    Returns:
        (thinned points with normals, the sensor's usual up, the up to use or None, where it came from:
            ``given``, ``imu`` or ``floor``).
    """
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


def _plan_points(scan: ScanPoints, levelled: Levelled, cfg: GlobalSearchConfig
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(the levelled (x, y) of the points that face sideways within the band, at most ``max_plan_points``
    (:func:`_plan_xy`); the cloud's points in the sensor frame, at most ``judge_points``: what refined candidates
    are judged on; the free-standing thing each of those belongs to, found on the whole cloud: :func:`view_things`).
    One generator draws both, in that order."""
    rng = np.random.default_rng(0)
    xy = _plan_xy(scan, levelled, cfg, rng)
    things = view_things(scan, levelled, cfg)
    view = scan.points
    if len(view) > cfg.judge_points:
        pick = rng.choice(len(view), cfg.judge_points, replace=False)
        view, things = view[pick], things[pick]
    return xy, view, things


def _plan_xy(scan: ScanPoints, levelled: Levelled, cfg: GlobalSearchConfig, rng: np.random.Generator
             ) -> np.ndarray:
    """The levelled (x, y) of the points that face sideways within the band, thinned to half a cell, at most
    ``max_plan_points`` (an even draw by ``rng``)."""
    points = scan.points @ levelled.R_level_sensor.T
    normals = scan.normals @ levelled.R_level_sensor.T
    height = points[:, 2] + levelled.height
    sideways = np.isfinite(normals[:, 2]) & (np.abs(np.nan_to_num(normals[:, 2], nan=1.0)) < cfg.wall_normal_z)
    keep = sideways & (height >= cfg.band[0]) & (height <= cfg.band[1])
    xy = _thinned(points[keep, :2], cfg.resolution / 2)
    if len(xy) > cfg.max_plan_points:
        xy = xy[rng.choice(len(xy), cfg.max_plan_points, replace=False)]
    return xy


def view_things(scan: ScanPoints, levelled: Levelled, cfg: GlobalSearchConfig) -> np.ndarray:
    """The free-standing thing each of the cloud's points belongs to (:func:`~.pieces.free_standing`, with the
    search's ``thing_*`` settings), their heights above the floor ``levelled`` found.

    Args:
        scan: The thinned cloud, sensor frame.
        levelled: The sensor's tilt and height above the floor.
        cfg: The search's settings.

    Returns:
        (N,) labels, negative for a point in no thing.
    """
    height = (scan.points @ levelled.R_level_sensor.T)[:, 2] + levelled.height
    return free_standing(scan.points, height, cfg.thing_link, cfg.thing_floor, cfg.thing_extent)


def view_scores(view: np.ndarray, things: np.ndarray | None, scene: OccludedMap, cfg: GlobalSearchConfig
                ) -> tuple[ViewScore, ViewScore]:
    """The whole view's likelihood as the search scores its candidates: (with the fix's tolerances, for a fixed
    pose; with ``screen_tolerance``, for a coarse one), free-standing things counted whole.

    Args:
        view: The points judged, sensor frame, m.
        things: (len(view),) their things (:func:`view_things`), or None to count every point on its own.
        scene: The model's occluded map.
        cfg: The search's settings.

    Returns:
        (judge, screen).
    """
    judge = ViewScore(view, scene, 2 * cfg.fix.inlier_distance, cfg.fix.behind_tolerance, things, cfg.thing_whole)
    screen = ViewScore(view, scene, cfg.screen_tolerance, cfg.screen_tolerance, things, cfg.thing_whole)
    return judge, screen


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


def quick_settings(scan: ScanPoints, cfg: GlobalSearchConfig) -> tuple[ScanPoints, LocalizationConfig]:
    """The thinner cloud, ray cast and wider basin every coarse peak is first fixed with (``quick_points``,
    ``quick_ray_deg``, ``quick_basin``: a coarse peak is a guess, not a prior); the contenders are then fixed
    again with the full cloud and settings.

    Args:
        scan: The thinned cloud (:func:`prepared`'s).
        cfg: The search's settings.

    Returns:
        (at most ``quick_points`` of the cloud, an even draw; the quick fix's settings).
    """
    quick = cfg.fix.model_copy(update={"cloud_ray_deg": max(cfg.fix.cloud_ray_deg, cfg.quick_ray_deg),
                                       "min_points": min(cfg.fix.min_points, cfg.quick_points // 8),
                                       "min_inliers": min(cfg.fix.min_inliers, cfg.quick_points // 10),
                                       "max_correction": cfg.quick_basin * cfg.fix.max_correction,
                                       "max_correction_deg": cfg.quick_basin * cfg.fix.max_correction_deg})
    if len(scan.points) <= cfg.quick_points:
        return scan, quick
    pick = np.random.default_rng(0).choice(len(scan.points), cfg.quick_points, replace=False)
    return ScanPoints(scan.points[pick], scan.normals[pick]), quick


def _refined_peaks(scan: ScanPoints, model: BimModel, levelled: Levelled, peaks: list, cfg: GlobalSearchConfig,
                   judge: ViewScore, screen: ViewScore) -> list[Candidate]:
    """The peaks screened by their view score at the coarse pose (``screen``: loose tolerances, as a coarse pose
    is a cell and a heading step off), then quickly fixed best screen first. A peak whose screen score is below
    the best fix's score by more than noise and ``screen_slack`` cannot tie with it (the fix of a right place
    scored up to 0.1 above its screen on the tour: an edge a few centimetres off hides what lies past it) and is
    not fixed; after ``candidates`` fixes the rest are left unchecked (``extra["unchecked"]``: :func:`choose` counts those that might tie)."""
    quick_scan, quick_cfg = quick_settings(scan, cfg)
    starts = [_start(levelled, peak) for peak in peaks]
    ranked = sorted(((screen(c.pose), c) for c in starts), key=lambda sc: -sc[0])
    out: list[Candidate] = []
    fixed = 0
    for screened, start in ranked:
        start = replace(start, score=screened, extra={"screen_score": round(screened, 4)})
        best = max((c.score for c in out if c.refined), default=None)
        if best is not None and screened < best - noise(best, cfg) - cfg.screen_slack:
            out.append(replace(start, reason=f"not fixed: its view scores {screened:.2f} at the coarse pose, "
                                             f"too far below the best fix's {best:.2f} to tie with it"))
        elif fixed >= cfg.candidates:
            out.append(replace(start, reason=f"not fixed: the search fixes at most {cfg.candidates} places",
                               extra={**start.extra, "unchecked": True}))
        else:
            fixed += 1
            out.append(fixed_candidate(quick_scan, model, start, quick_cfg, judge))
    return out


def _start(levelled: Levelled, peak) -> Candidate:
    """The coarse peak as an unrefined candidate: its cell and heading, levelled, at the floor's height."""
    coarse, plan, xy, yaw = peak
    start = np.eye(4)
    start[:3, :3] = rz(yaw) @ levelled.R_level_sensor
    start[:3, 3] = (xy[0], xy[1], plan.floor_z + levelled.height)
    return Candidate(start, coarse, None, [], False, coarse_score=coarse, storey=plan.name, gravity=levelled.gravity)


def fixed_candidate(scan: ScanPoints, model: BimModel, candidate: Candidate, fix_cfg: LocalizationConfig,
                    judge: ViewScore) -> Candidate:
    """``candidate`` fixed by :func:`localize_cloud` from its pose and scored by ``judge``, or refused with the
    reason (keeping its pose and score).

    Args:
        scan: The thinned cloud, sensor frame.
        model: The BIM, loaded with geometry.
        candidate: The place to fix from (its ``pose`` T_world_sensor).
        fix_cfg: The fix's settings (the full ones, or :func:`quick_settings`').
        judge: The whole view's likelihood the fixed pose is scored by.

    Returns:
        The candidate fixed (``refined``, with its covariance and free directions) or refused (``reason``).
    """
    try:
        fix = localize_cloud(scan, model, candidate.pose, (0.0, 0.0, 1.0), fix_cfg)
    except LocalizationError as error:
        return replace(candidate, refined=False, reason=str(error), covariance=None, degenerate=[])
    extra = {**candidate.extra, "degenerate_yaw": True} if fix.degenerate_yaw else candidate.extra
    return replace(candidate, pose=fix.pose, score=judge(fix.pose), covariance=fix.covariance,
                   degenerate=list(fix.degenerate), refined=True, reason=None, inliers=fix.inliers,
                   residual=fix.residual, extra=extra)


def _unique(candidates: list[Candidate], cfg: GlobalSearchConfig) -> list[Candidate]:
    """Accepted candidates by score, then refused ones by score; of those that are one place (:func:`same_place`),
    the best only."""
    ordered = sorted(candidates, key=lambda c: (not c.refined, -c.score))
    kept: list[Candidate] = []
    for c in ordered:
        if not any(same_place(c, k, cfg) for k in kept if k.refined == c.refined):
            kept.append(c)
    return kept


def same_place(a: Candidate, b: Candidate, cfg: GlobalSearchConfig) -> bool:
    """Whether two candidates are one place counted twice: headings within ``same_place_deg`` and positions
    within ``same_place`` m or three standard deviations of either fix (its covariance), whichever is more, once
    what lies along a direction either view cannot fix is set aside (a single wall's fixes slide along it).

    Args:
        a: A candidate.
        b: Another.
        cfg: The search's settings.

    Returns:
        True when they are the same place.
    """
    relative = a.pose[:3, :3] @ b.pose[:3, :3].T
    if abs(np.arctan2(relative[1, 0], relative[0, 0])) >= np.deg2rad(cfg.same_place_deg):
        return False
    offset = a.pose[:3, 3] - b.pose[:3, 3]
    for direction in [*a.degenerate, *b.degenerate]:
        unit = np.asarray(direction, dtype=np.float64) / max(float(np.linalg.norm(direction)), 1e-12)
        offset = offset - unit * (offset @ unit)
    reach = cfg.same_place
    for c in (a, b):
        if c.covariance is not None and not c.degenerate:
            reach = max(reach, 3.0 * float(np.sqrt(np.linalg.eigvalsh(c.covariance[:3, :3]).max())))
    return bool(np.linalg.norm(offset) < reach)
