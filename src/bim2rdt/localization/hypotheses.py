"""Multi-hypothesis global localization through a sweep: the places one view cannot tell apart, carried from frame
to frame by odometry until one is left (AMCL's global localization does the same with particles).

1. a frame is searched globally (:func:`~bim2rdt.localization.find_pose`); when :func:`choose` takes its best,
   the sweep is found. Otherwise every place that fits within noise of the best (:func:`fitting`: the fix
   accepted it, or left it unchecked for the budget) becomes a hypothesis (``T_world_sensor`` each);
2. for each next frame, every hypothesis is moved by the odometry step ``T_previous_current`` (a source's own
   poses used as odometry, or ICP between frames), levelled to the frame's IMU up when there is one, fixed on
   the new frame by the 4-DoF fix (the global search's quick fix: a wider basin, for the odometry's drift) and
   scored by the whole view's likelihood (:class:`~bim2rdt.localization.view_score.ViewScore`), as
   :func:`find_pose` scores its candidates. Fixes of one place merge (within ``same_place`` m and
   ``same_place_deg``; never along a direction a view leaves free, as the search's merge does: two hypotheses a
   wall's length apart stay two while the view shows only that wall);
3. a hypothesis whose fix is refused is kept only while its view, at the moved pose and with the search's loose
   screen, still scores within noise and ``screen_slack`` of the best fix (as :func:`find_pose` counts a peak it
   left unfixed: a place that might fit is never dropped unseen); one whose score falls below the best by more
   than noise is dropped;
4. :func:`choose` on what is left: exactly one place, fixing every direction, is taken (fixed again in full);
   while two fit, nothing is. When every hypothesis is refused the sweep searches the frame globally again;
5. while two or more hypotheses are carried, the new frame is also searched on its own (``recheck``): a place
   found alone where a carried one stands resolves them. When the frame's own best place scores above every
   carried one by more than noise, or is found alone away from them, the carried places and the frame disagree
   (the first search missed the true place, or this frame's search is fooled: clutter that a wall explains
   elsewhere): the carried places go on, and none is taken at that frame. The first frame of a sweep, found on
   its own, is taken at once, as :func:`find_pose` would.

Once one place is taken the sweep tracks it: the next frame's hypothesis is that place moved by the odometry
(steps 2-4 with one hypothesis). The frames held while the view was ambiguous (at most ``hold``) get their
poses back through the odometry chain (:attr:`SweepStep.backfill`): ``T_resolved @ inv(T_held_resolved)``, to be
fixed from there.

A view that leaves a direction free (one bare wall) cannot say where along it the sensor stands. The sweep
calibrates its odometry on its own fixes (:mod:`~bim2rdt.localization.calibration`: the legs between consecutive
frames fixed in every direction) and takes such a frame (``how`` ``"calibrated"``) when the calibrated odometry
from the frame before places it along the free direction well within ``calibration.free_tolerance``; else it is
refused as before, and :meth:`Sweep.smooth` may take it at the end from the fixes on both sides (decision 0053).
Only the data and the odometry are read: no truth, no prior.
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field, replace

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.localization.calibration import (CAMERA_FORWARD, SCANNER_FORWARD, OdometryCalibration, along_free,
                                              calibrate, leg_error)
from bim2rdt.localization.cloud import OccludedMap, ScanPoints
from bim2rdt.localization.errors import LocalizationError
from bim2rdt.localization.global_config import GlobalSearchConfig
from bim2rdt.localization.global_search import (Candidate, choose, find_pose, fixed_candidate, noise, prepared,
                                                  quick_settings, view_scores, view_things)
from bim2rdt.localization.gravity import level, level_rotation
from bim2rdt.localization.planar import rz
from bim2rdt.localization.view_score import ViewScore
from bim2rdt.perception import Frame


@dataclass(frozen=True)
class SweepStep:
    """What one frame of a sweep gave.

    ``pose`` (4, 4 T_world_sensor) is taken only when exactly one place fits and its view fixes every direction,
    else None and ``reason`` says why (``"ambiguous: N places fit"``, a free direction, no place). ``places`` are
    the hypotheses left after this frame, best first (JSON: :meth:`Candidate.to_json`); ``how`` is ``"search"``
    (this frame's own global search decided), ``"carried"`` (hypotheses carried from earlier frames decided) or
    ``"tracked"`` (the one place carried on); ``candidates`` this frame's own global search's, when it ran;
    ``resolved_at`` the sweep's frame number at which the carried ambiguity was resolved (this frame, or None);
    ``backfill`` (frame number, prior pose T_world_sensor) of each frame held while ambiguous, now known through
    the odometry chain; ``seconds`` the step's CPU time; ``calibration`` the odometry's calibration
    (:meth:`OdometryCalibration.to_json`) when it was weighed for a direction the view leaves free (``how`` is
    ``"calibrated"`` when the pose was taken with it)."""

    pose: np.ndarray | None
    reason: str
    places: list[Candidate]
    how: str
    candidates: list[Candidate] = field(default_factory=list)
    resolved_at: int | None = None
    backfill: list[tuple[int, np.ndarray]] = field(default_factory=list)
    seconds: float = 0.0
    calibration: dict | None = None


class Sweep:
    """Multi-hypothesis localization of a sequence of frames or clouds on one model (see the module's note):
    :meth:`add` each frame in order with the odometry step from the previous one.

    Args:
        model: The BIM, loaded with geometry.
        config: The global search's settings (its fix, noise and screen); None uses the defaults.
        storey: The storey (name or GlobalId) a global search looks in; None: every storey.
        hold: At most this many ambiguous frames are held for the back-fill (the oldest go first).
        recheck: Search each frame on its own too while two or more places are carried (step 5).
        refused_before_search: After this many frames in a row where every hypothesis was refused, the next
            frame is searched globally.

    The record the odometry is calibrated from, by frame number (the latest only): ``steps`` the odometry step
    into each frame, ``fixes`` the frames fixed in every direction (:meth:`confirm`), ``free`` those fixed but
    along a free direction and refused (pose, free world directions), for :meth:`smooth`; ``forward`` the
    sensor's heading axis (a camera's optical axis, a scanner's x).
    """

    def __init__(self, model: BimModel, config: GlobalSearchConfig | None = None, storey: str | None = None,
                 hold: int = 8, recheck: bool = True, refused_before_search: int = 2) -> None:
        self.model, self.cfg, self.storey, self.recheck = model, config or GlobalSearchConfig(), storey, recheck
        self.places: list[Candidate] = []
        self.held: deque[tuple[int, np.ndarray]] = deque(maxlen=hold)
        self.count, self.refused, self.refused_before_search = 0, 0, refused_before_search
        self.steps: dict[int, np.ndarray] = {}
        self.fixes: dict[int, np.ndarray] = {}
        self.free: dict[int, tuple[np.ndarray, list[np.ndarray]]] = {}
        self._calibration: OdometryCalibration | None = None
        self.forward = CAMERA_FORWARD

    @property
    def scene(self) -> OccludedMap:
        """The model's occluded map (built, or the cached one taken, when first needed)."""
        return OccludedMap.of(self.model)

    @property
    def tracking(self) -> bool:
        """One place is carried: the sweep is found."""
        return len(self.places) == 1

    def add(self, data: object, T_previous_current: np.ndarray | None,
            up: np.ndarray | tuple[float, float, float] | None = None) -> SweepStep:
        """The next frame of the sweep.

        Args:
            data: A :class:`~bim2rdt.perception.Frame` or a cloud (``.points`` (N, 3), sensor frame, m).
            T_previous_current: The odometry step (4, 4): this frame's sensor pose in the previous frame's; None
                when unknown (the first frame, or odometry lost): the frame is searched on its own.
            up: Gravity up in the sensor frame (an IMU's); None takes the frame's IMU, else the floor plane.

        Returns:
            The frame's :class:`SweepStep`.
        """
        started = time.process_time()
        number, self.count = self.count, self.count + 1
        self._forget(number)
        self.forward = CAMERA_FORWARD if isinstance(data, Frame) else SCANNER_FORWARD
        if T_previous_current is not None:
            self.steps[number] = np.asarray(T_previous_current, dtype=np.float64)
        self.held = deque(((k, T @ T_previous_current) for k, T in self.held), maxlen=self.held.maxlen) \
            if T_previous_current is not None else deque(maxlen=self.held.maxlen)
        if self.places and T_previous_current is not None and self.refused < self.refused_before_search:
            step = self._carried(data, T_previous_current, up, number)
        else:
            step = self._searched(data, up)
        if step.pose is None and self.places:
            self.held.append((number, np.eye(4)))
        if step.pose is not None and step.how != "calibrated":
            self.confirm(number, step.pose)
        return replace(step, seconds=time.process_time() - started)

    @property
    def calibration(self) -> OdometryCalibration:
        """The odometry's calibration from the legs between consecutive frames fixed in every direction
        (:func:`~bim2rdt.localization.calibration.calibrate`; not ``valid`` while there are too few)."""
        if self._calibration is None:
            legs = [leg_error(self.fixes[k - 1], self.steps[k], self.fixes[k], self.forward)
                    for k in sorted(self.fixes) if k - 1 in self.fixes and k in self.steps]
            self._calibration = calibrate(legs, self.cfg.calibration)
        return self._calibration

    def confirm(self, number: int, pose: np.ndarray) -> None:
        """Record a frame fixed in every direction (a taken frame, or a held one fixed from its back-filled pose):
        the legs between such frames calibrate the odometry.

        Args:
            number: The frame's number in the sweep (0 for the first :meth:`add`).
            pose: Its fixed T_world_sensor (4, 4).
        """
        self.fixes[number] = np.asarray(pose, dtype=np.float64)
        self.free.pop(number, None)
        self._calibration = None

    def smooth(self) -> list[tuple[int, np.ndarray]]:
        """The frames refused because their view leaves a direction free, taken now when the calibrated odometry
        from the fixes before and after them (forward from the one before, back from the one after, fused)
        places them well within ``calibration.free_tolerance`` along it (for a whole recording, at its end).

        Returns:
            (frame number, T_world_sensor (4, 4)) of each frame taken; they leave the refused list.
        """
        calibration = self.calibration
        if not calibration.valid:
            return []
        taken = []
        for number, (pose, free) in sorted(self.free.items()):
            before = self._from_before(number, pose[:3, :3])
            estimates = [] if before is None else [before]
            if number + 1 in self.fixes and number + 1 in self.steps:
                moved, covariance, _ = calibration.displacement(pose[:3, :3], self.steps[number + 1], self.forward,
                                                                self.fixes[number + 1][:3, :3])
                estimates.append((self.fixes[number + 1][:3, 3] - moved, covariance))
            completed, _, _ = along_free(pose, free, estimates, calibration.legs, self.cfg.calibration)
            if completed is not None:
                taken.append((number, completed))
        for number, _ in taken:
            del self.free[number]
        return taken

    def _forget(self, number: int) -> None:
        """Keep the record of the latest frames only (enough for ``max_legs`` legs)."""
        keep = number - 4 * self.cfg.calibration.max_legs
        for record in (self.steps, self.fixes, self.free):
            for k in [k for k in record if k < keep]:
                del record[k]

    def _searched(self, data: object, up) -> SweepStep:
        """The frame searched on its own: taken when one place fits, else its fitting places are the hypotheses."""
        self.held.clear()
        self.refused = 0
        try:
            candidates = find_pose(data, self.model, up=up, config=self.cfg, storey=self.storey)
        except LocalizationError as error:
            self.places = []
            return SweepStep(None, f"global search: {error}", [], "search")
        return self._restarted(candidates)

    def _carried(self, data: object, T_previous_current: np.ndarray, up, number: int) -> SweepStep:
        """The hypotheses carried to this frame and narrowed (steps 2-5 of the module's note)."""
        was_tracking = self.tracking
        carried = carry(self.places, data, T_previous_current, self.model, up, self.cfg, self.scene)
        left = fitting(carried, self.cfg)
        if not left:
            self.refused += 1
            if self.refused >= self.refused_before_search:
                return self._searched(data, up)
            self.places = [replace(c, refined=False, extra={"unchecked": True}) for c in carried]
            return SweepStep(None, "no carried place fits this frame (carried on by odometry)", list(self.places),
                             "tracked" if was_tracking else "carried")
        self.refused = 0
        fresh: list[Candidate] = []
        conflict = False
        if self.recheck and len(left) > 1:
            try:
                fresh = find_pose(data, self.model, up=up, config=self.cfg, storey=self.storey)
            except LocalizationError:
                fresh = []
            alone, _ = choose(fresh, self.cfg)
            if alone is not None and any(_near(alone.pose, c.pose, self.cfg) for c in left):
                left = [replace(alone, extra={**alone.extra, "full": True})]  # where a carried place stands
            else:
                conflict = alone is not None or _beaten(left, fresh, self.cfg)
        self.places = left
        taken, reason = choose(left, self.cfg)
        if conflict and taken is not None:
            taken, reason = None, "the frame alone fits a place the carried ones do not: carried on unconfirmed"
        if taken is not None and not taken.extra.get("full"):
            taken = self._full(data, taken, up)
            if taken is None:
                reason = "the carried place's full fix was refused"
        how = "tracked" if was_tracking else "carried"
        if taken is None and was_tracking and not conflict and len(left) == 1 and left[0].degenerate:
            return self._along_free(data, left[0], up, number, reason, fresh)
        if taken is None:
            return SweepStep(None, reason, list(left), how, fresh)
        self.places = [taken]
        backfill = [(k, taken.pose @ np.linalg.inv(T)) for k, T in self.held]
        self.held.clear()
        return SweepStep(taken.pose, "", [taken], how, fresh, number if backfill else None, backfill)

    def _restarted(self, fresh: list[Candidate]) -> SweepStep:
        """Start over from the frame's own candidates. A place whose view leaves a direction free is no
        hypothesis: where along that direction it stands is not known (its fixes along a wall were merged into
        one), so nothing is carried and the next frame is searched again."""
        self.held.clear()
        taken, reason = choose(fresh, self.cfg)
        places = [taken] if taken is not None else fitting(fresh, self.cfg)
        self.places = [] if any(c.degenerate for c in places) else places
        return SweepStep(None if taken is None else taken.pose, reason, list(self.places), "search", fresh)

    def reset(self) -> None:
        """Forget every place, and the record the odometry is calibrated from: the next frame is searched on its
        own."""
        self.places, self.refused = [], 0
        self.held.clear()
        self.steps, self.fixes, self.free, self._calibration = {}, {}, {}, None

    def _along_free(self, data: object, place: Candidate, up, number: int, reason: str, fresh: list[Candidate]
                    ) -> SweepStep:
        """The one place carried, whose view leaves a direction free (a bare wall): fixed in full, and taken when
        the calibrated odometry from the previous frame's fix places it well within ``free_tolerance`` along that
        direction (:func:`~bim2rdt.localization.calibration.along_free`); else refused and recorded for
        :meth:`smooth`."""
        full = self._full(data, place, up, free=True)
        if full is None or not full.degenerate or full.extra.get("degenerate_yaw"):
            return SweepStep(None, reason, [place], "tracked", fresh)
        self.places = [full]
        self.free[number] = (full.pose, list(full.degenerate))
        calibration = self.calibration
        before = self._from_before(number, full.pose[:3, :3]) if calibration.valid else None
        if before is None:
            why = calibration.reason if not calibration.valid else "no fix on the frame before"
            return SweepStep(None, f"{reason}; odometry not calibrated: {why}", [full], "tracked", fresh,
                             calibration=calibration.to_json())
        pose, sigma, why = along_free(full.pose, full.degenerate, [before], calibration.legs, self.cfg.calibration)
        if pose is None:
            return SweepStep(None, f"{reason}; {why}", [full], "tracked", fresh, calibration=calibration.to_json())
        taken = replace(full, pose=pose, extra={**full.extra, "calibrated": True, "free_sigma": round(sigma, 4)})
        self.places = [taken]
        del self.free[number]
        return SweepStep(pose, "", [taken], "calibrated", fresh, calibration=calibration.to_json())

    def _from_before(self, number: int, R_end: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """Where the calibrated odometry puts frame ``number`` from the fix on the frame before, given the heading
        ``R_end`` (3, 3) fixed at it: (position (3,) m, covariance (3, 3) m^2), or None without that fix or
        step."""
        if number - 1 not in self.fixes or number not in self.steps:
            return None
        predicted, covariance = self.calibration.predict(self.fixes[number - 1], self.steps[number], self.forward,
                                                         R_end)
        return predicted[:3, 3], covariance

    def _full(self, data: object, taken: Candidate, up, free: bool = False) -> Candidate | None:
        """The taken place fixed again with the whole cloud and the fix's own settings (as :func:`find_pose` does
        the one place that stands out); None when that fix is refused or (unless ``free``) leaves a direction
        free."""
        scan, default_up, up_sensor, gravity = prepared(data, up, self.cfg)
        judge = _judge(scan, (default_up, up_sensor, gravity), self.scene, self.cfg)
        fixed = fixed_candidate(scan, self.model, replace(taken, pose=levelled(taken.pose, up_sensor)),
                                self.cfg.fix, judge)
        if not fixed.refined or (fixed.degenerate and not free):
            return None
        return replace(fixed, extra={**fixed.extra, "full": True})


def carry(places: list[Candidate], data: object, T_previous_current: np.ndarray, model: BimModel,
          up: np.ndarray | tuple[float, float, float] | None = None, config: GlobalSearchConfig | None = None,
          scene: OccludedMap | None = None) -> list[Candidate]:
    """Each place moved by the odometry step and fixed on the new frame (steps 2-3 of the module's note).

    Args:
        places: The hypotheses on the previous frame (``pose`` T_world_sensor each).
        data: The new frame or cloud.
        T_previous_current: The odometry step (4, 4): the new sensor pose in the previous one's frame.
        model: The BIM, loaded with geometry.
        up: Gravity up in the new frame's sensor frame; None takes the frame's IMU (else none: the moved poses
            keep their tilt).
        config: The global search's settings; None uses the defaults.
        scene: The model's occluded map when the caller holds it.

    Returns:
        The carried places, fixed ones by score then refused ones, one per place; a refused one carries its
            screen score (``extra["screen_score"]``) and is ``extra["unchecked"]`` while that score might tie with
            the best fix (:func:`fitting` keeps it).
    """
    cfg = config or GlobalSearchConfig()
    scene = scene or OccludedMap.of(model)
    scan, default_up, up_sensor, gravity = prepared(data, up, cfg)
    quick_scan, quick_cfg = quick_settings(scan, cfg)
    judge, screen = view_scores(*_judged(scan, (default_up, up_sensor, gravity), cfg), scene, cfg)
    moved = [Candidate(levelled(p.pose @ T_previous_current, up_sensor), p.score, None, [], False, p.coarse_score,
                       p.storey, p.gravity) for p in places]
    fixed = [fixed_candidate(quick_scan, model, m, quick_cfg, judge) for m in moved]
    best = max((c.score for c in fixed if c.refined), default=None)
    out = [c for c in fixed if c.refined]
    for c in (c for c in fixed if not c.refined):
        screened = screen(c.pose)
        tie = best is None or screened >= best - noise(best, cfg) - cfg.screen_slack
        out.append(replace(c, score=screened, extra={"screen_score": round(screened, 4), "unchecked": tie}))
    return _merged(out, cfg)


def refix(data: object, prior: np.ndarray, model: BimModel,
          up: np.ndarray | tuple[float, float, float] | None = None, config: GlobalSearchConfig | None = None
          ) -> Candidate:
    """A frame fixed in full from a known place (a held frame's back-filled pose), levelled to its IMU up and
    scored as :func:`find_pose` scores its candidates.

    Args:
        data: The frame or cloud.
        prior: T_world_sensor (4, 4) to fix from (:attr:`SweepStep.backfill`'s).
        model: The BIM, loaded with geometry.
        up: Gravity up in the sensor frame; None takes the frame's IMU (else the prior's tilt is kept).
        config: The global search's settings (its ``fix``); None uses the defaults.

    Returns:
        The fixed candidate (``refined``), or the prior refused with the fix's ``reason``.
    """
    cfg = config or GlobalSearchConfig()
    scan, default_up, up_sensor, gravity = prepared(data, up, cfg)
    scene = OccludedMap.of(model)
    start = Candidate(levelled(np.asarray(prior, dtype=np.float64), up_sensor), 0.0, None, [], False, 0.0, "", "")
    judge = _judge(scan, (default_up, up_sensor, gravity), scene, cfg)
    return fixed_candidate(scan, model, start, cfg.fix, judge)


def fitting(candidates: list[Candidate], config: GlobalSearchConfig | None = None) -> list[Candidate]:
    """The places that fit within noise of the best fix: fixed ones, and those left unchecked whose screen
    might tie (what :func:`choose` counts), best first; none when no place was fixed.

    Args:
        candidates: :func:`find_pose`'s or :func:`carry`'s answer.
        config: The search's settings (its noise); None uses the defaults.

    Returns:
        The hypotheses to carry.
    """
    cfg = config or GlobalSearchConfig()
    fits = [c for c in candidates if c.refined]
    if not fits:
        return []
    best = fits[0].score
    return [c for c in candidates if (c.refined or c.extra.get("unchecked")) and c.score >= best - noise(best, cfg)]


def levelled(pose: np.ndarray, up_sensor: np.ndarray | None) -> np.ndarray:
    """``pose`` (4, 4 T_world_sensor) turned so that ``up_sensor`` (gravity up in the sensor frame, an IMU's)
    maps onto world +z, its heading and position kept; unchanged when ``up_sensor`` is None."""
    if up_sensor is None:
        return pose
    up = np.asarray(up_sensor, dtype=np.float64)
    R_level_sensor = level_rotation(up / np.linalg.norm(up))
    forward = pose[:3, :3] @ R_level_sensor[0]
    out = pose.copy()
    out[:3, :3] = rz(float(np.arctan2(forward[1], forward[0]))) @ R_level_sensor
    return out


def _judged(scan: ScanPoints, prep: tuple, cfg: GlobalSearchConfig) -> tuple[np.ndarray, np.ndarray | None]:
    """At most ``judge_points`` of the cloud (an even draw), sensor frame, and the free-standing thing each belongs
    to (:func:`~.global_search.view_things`, as :func:`find_pose` finds them), or None when no floor is in view to
    find them by. ``prep`` is :func:`prepared`'s (default up, up, gravity)."""
    points, things = scan.points, None
    if cfg.thing_whole > 0:
        default_up, up, gravity = prep
        try:
            things = view_things(scan, level(scan, up, gravity, default_up, cfg.floor_cone_deg,
                                             cfg.min_floor_points), cfg)
        except LocalizationError:
            things = None
    if len(points) > cfg.judge_points:
        pick = np.random.default_rng(0).choice(len(points), cfg.judge_points, replace=False)
        points, things = points[pick], None if things is None else things[pick]
    return points, things


def _judge(scan: ScanPoints, prep: tuple, scene: OccludedMap, cfg: GlobalSearchConfig) -> ViewScore:
    """The whole view's likelihood with the fix's tolerances, free-standing things counted whole (how
    :func:`find_pose` scores its candidates)."""
    return view_scores(*_judged(scan, prep, cfg), scene, cfg)[0]


def _merged(candidates: list[Candidate], cfg: GlobalSearchConfig) -> list[Candidate]:
    """Fixed places by score, then refused ones; of those within ``same_place`` m and ``same_place_deg`` of a
    better one, the best only. Unlike a search's merge, places are never merged along a direction a view leaves
    free: two hypotheses a wall's length apart stay two while the view shows only that wall."""
    ordered = sorted(candidates, key=lambda c: (not c.refined, -c.score))
    kept: list[Candidate] = []
    for c in ordered:
        if not any(_near(c.pose, k.pose, cfg) for k in kept):
            kept.append(c)
    return kept


def _near(a: np.ndarray, b: np.ndarray, cfg: GlobalSearchConfig) -> bool:
    turn = a[:3, :3] @ b[:3, :3].T
    return bool(np.linalg.norm(a[:3, 3] - b[:3, 3]) < cfg.same_place
                and abs(np.arctan2(turn[1, 0], turn[0, 0])) < np.deg2rad(cfg.same_place_deg))


def _beaten(left: list[Candidate], fresh: list[Candidate], cfg: GlobalSearchConfig) -> bool:
    """The frame's own best place scores above every carried place by more than noise: the carried ones lost
    the true place."""
    fits = [c for c in fresh if c.refined]
    if not fits:
        return False
    carried = max(c.score for c in left if c.refined) if any(c.refined for c in left) else -1.0
    return fits[0].score > carried + noise(fits[0].score, cfg)
