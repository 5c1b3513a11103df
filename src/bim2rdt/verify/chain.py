"""``verify``: a real recording or scan checked against its BIM, frame by frame.

For each frame: its points (sensor frame) -> :func:`~bim2rdt.localization.localize_cloud` on the permanent
elements from the prior -> the depth check (:mod:`.depth_check`) -> the points the permanent structure does not
explain -> each planned object in view checked by its own body (:mod:`.planned`) -> what is left, clustered,
as new objects (:mod:`.new_objects`). The observations are recorded into a twin by the caller
(:mod:`.outputs`). A frame whose fix is refused carries the reason; a frame whose depth looks miscalibrated
has its observations unverified, with the reason.
"""

from __future__ import annotations

import time as clock
from collections import Counter
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.localization import GlobalSearchConfig, LocalizationConfig, LocalizationError, localize_cloud
from bim2rdt.localization.cloud import OccludedMap, scan_points
from bim2rdt.perception.background import explained, structure_for
from bim2rdt.perception.frame import Frame
from bim2rdt.perception.observation import Observation
from bim2rdt.perception.structure import movable_elements
from bim2rdt.semantics import KnowledgeBasePriors, UprightPrior
from bim2rdt.twin import ElementStatus, TwinConfig
from bim2rdt.twin.verdict import fit_trusted
from bim2rdt.verify.depth_check import DepthCheck, DepthCheckConfig, check_depth
from bim2rdt.verify.errors import VerifyError
from bim2rdt.verify.new_objects import NewObjectConfig, new_objects
from bim2rdt.verify.planned import PlannedConfig, check_planned, planned_in_view, seen_empty
from bim2rdt.verify.priors import levelled
from bim2rdt.verify.rays import RangeLookup
from bim2rdt.verify.tracking import Tracker


def real_sensor_localization() -> LocalizationConfig:
    """Localization settings for consumer RGB-D cameras and scanners at up to ~5 m: a Kinect's depth noise is
    ~3 cm at 4.7 m (structured light grows with z^2), so inliers reach 5 cm and the Huber scale 2.5 cm; a real
    room has its furniture in front of half the walls, so 30 % of the points near the map suffice."""
    return LocalizationConfig(inlier_distance=0.05, huber_delta=0.025, min_inlier_fraction=0.3)


@dataclass(frozen=True)
class VerifyConfig:
    """The knobs of verify. ``depth_noise`` (a, b): the sensor's depth sigma is a + b z^2 metres at depth z
    (Kinect v1, Khoshelham & Elberink 2012: ~1.4 mm/m^2), used where a point is judged on or off a wall."""

    localization: LocalizationConfig = field(default_factory=real_sensor_localization)
    planned: PlannedConfig = field(default_factory=PlannedConfig)
    new: NewObjectConfig = field(default_factory=NewObjectConfig)
    depth: DepthCheckConfig = field(default_factory=DepthCheckConfig)
    depth_noise: tuple[float, float] = (0.002, 0.0015)
    surface_tolerance: float = 0.03
    """A point this close to a permanent surface (plus 3 sigma of depth noise) is the building's."""
    min_fitness: float = TwinConfig().min_fitness
    """A fit with less of its points on the body than this is no evidence the object is there (the twin's
    ``min_fitness``, ``Settings.twin.min_fitness``: the edge passes it): its place may be judged seen empty instead."""
    find_new: bool = True
    """Cluster what neither the building nor a planned object explains into new objects."""


@dataclass
class FrameResult:
    """One frame or scan: where it came from, the fix (or why not), the depth check, what was found, seconds."""

    index: int
    source: str
    time: float | None
    prior: np.ndarray | None
    pose: np.ndarray | None = None
    covariance: np.ndarray | None = None
    degenerate: list = field(default_factory=list)
    residual: float | None = None
    inliers: int = 0
    accepted: bool = False
    reason: str = ""
    depth: DepthCheck | None = None
    observations: list[Observation] = field(default_factory=list)
    missing: list[str] = field(default_factory=list)
    """GlobalIds of planned objects in view whose place the sensor saw empty."""
    seconds: float = 0.0
    recorded: np.ndarray | None = None
    """The frame's own pose as the recording gave it (a bag's camera in its world frame), or None."""
    prior_source: str = ""
    """Where the prior came from: ``global``, ``tracked``, ``source`` or ``user`` (:mod:`.tracking`)."""
    candidates: list[dict] = field(default_factory=list)
    """The global search's candidates (JSON), when it ran for this frame."""

    def to_dict(self) -> dict:
        """The frame's entry in localization.json.

        Returns:
            JSON-ready fields: poses and covariances as nested lists (metres, radians), ``reason`` when refused.
        """
        entry = {"source": self.source, "time": self.time,
                 "pose": None if self.pose is None else self.pose.tolist(),
                 "covariance": None if self.covariance is None else self.covariance.tolist(),
                 "degenerate": [np.asarray(d).tolist() for d in self.degenerate], "residual": self.residual,
                 "inliers": self.inliers, "accepted": self.accepted,
                 "prior": None if self.prior is None else self.prior.tolist(),
                 "depth_check": self.depth.to_dict() if self.depth else None, "missing": self.missing,
                 "seconds": round(self.seconds, 3), "prior_source": self.prior_source}
        if self.candidates:
            entry["candidates"] = self.candidates
        if not self.accepted:
            entry["reason"] = self.reason
        return entry


@dataclass
class VerifyResult:
    """Every frame's result in source order."""

    frames: list[FrameResult]
    dropped: list[dict] = field(default_factory=list)
    """Frames the source dropped before verify saw them (a bag's: no depth partner, no TF within the tolerance),
    each ``{"time", "reason"}``."""
    source_warnings: list[str] = field(default_factory=list)
    """What the source found off about the recording as a whole (a bag whose clocks disagree)."""

    @property
    def drop_counts(self) -> dict[str, int]:
        """{kind (or reason): number} of the frames the source dropped."""
        return dict(Counter(d.get("kind", d["reason"]) for d in self.dropped))

    @property
    def miscalibrated(self) -> bool:
        """True when any frame's depth check found the depth miscalibrated."""
        return any(f.depth is not None and f.depth.miscalibrated for f in self.frames)

    @property
    def warnings(self) -> list[str]:
        """One line per frame whose depth check found it miscalibrated, with the reason."""
        return [f"frame {f.index} ({f.source}): {f.depth.reason}" for f in self.frames
                if f.depth is not None and f.depth.miscalibrated]


def verify_frames(frames: Iterable, model: BimModel, prior: np.ndarray | None = None,
                  config: VerifyConfig = VerifyConfig(),
                  progress: Callable[[FrameResult], None] | None = None,
                  priors: Mapping[str, UprightPrior] | None = None, storey: str | None = None) -> VerifyResult:
    """Each frame of ``frames`` localized on ``model`` and checked (see the module's note). An item is a
    :class:`Frame` or a scan (anything with ``.points`` (N, 3) in the sensor frame, and ``.path``: a
    ``sources.Cloud``). Each item's prior:

    - with ``prior`` (4, 4 T_world_sensor, the model's frame) and frames that carry poses (a recording's own,
      in whatever frame it keeps them): those poses are odometry, anchored at the last accepted fix (at first,
      ``prior`` for the first frame): prior_i = T_fix_k @ inv(T_own_k) @ T_own_i;
    - with ``prior`` and camera frames without poses: ``prior`` for the first, then the last fix (or the last
      prediction) composed with frame-to-frame odometry (``tracked``); a scan: the last fix, else ``prior``;
    - without ``prior``: the frame's own pose, taken as in the model's frame, until a fix is accepted: from then
      on the own poses are odometry anchored at the last fix, as with ``prior`` (a ROS bag's camera in ``map``:
      the fix is what map -> odom should be);
    - without ``prior`` or poses: the BIM is searched globally (:func:`~bim2rdt.localization.find_pose`) for
      the first frame, each scan, and a frame after two refused fixes in a row; the frames in between are
      tracked. An ambiguous view is refused ("ambiguous: N places fit") with every candidate listed.
      Each result's ``prior_source`` says which (:mod:`.tracking`).

    A source that drops frames (``dropped``: a list of ``{"time", "reason"}``, read after iterating) or warns about
    the recording (``warnings``) has them carried into the result.

    Args:
        frames: The frames or scans, in the order they were taken (a ``FrameSource`` or any iterable).
        model: The BIM, loaded with geometry.
        prior: ``T_world_sensor`` (4x4, metres) of the first frame in the model's frame; None trusts the
            frames' own poses until a fix is accepted, or searches the BIM when they have none.
        config: Localization, depth check and perception settings.
        progress: Called with each frame's result as it is done.
        priors: Family -> upright prior, to fit each planned object as the mission fits it (default:
            :func:`family_priors` of ``model``).
        storey: The storey (name or GlobalId) a global search looks in; None searches every storey.

    Returns:
        Every frame's result in source order, with what the source dropped and warned about.

    Raises:
        VerifyError: The source holds no frames, or the model has nothing to localize on.
    """
    try:
        scene = OccludedMap.of(model)
    except LocalizationError as error:
        raise VerifyError(str(error)) from None
    priors = family_priors(model) if priors is None else priors
    results: list[FrameResult] = []
    tracker = Tracker(model, prior, GlobalSearchConfig(fix=config.localization), storey)
    for index, frame in enumerate(frames):
        guess = tracker.prior(frame, sensor_points(frame))
        result = verify_frame(index, frame, model, scene, guess.pose, config, priors)
        result.recorded = frame.T_world_camera if isinstance(frame, Frame) else None
        result.prior_source, result.candidates = guess.source, guess.candidates
        if guess.pose is None and guess.reason:
            result.reason = guess.reason
        tracker.update(guess, result.pose, result.accepted)
        results.append(result)
        if progress is not None:
            progress(result)
    dropped = list(getattr(frames, "dropped", []))
    if not results:
        reasons = "; ".join(f"{n} {k}" for k, n in Counter(d["reason"] for d in dropped).most_common(3))
        raise VerifyError("the source holds no frames" + (f" (all {len(dropped)} dropped: {reasons})" if dropped
                                                          else ""))
    kinds = getattr(frames, "drop_kind", None)
    if kinds is not None:
        dropped = [{**d, "kind": kinds(d["reason"])} for d in dropped]
    return VerifyResult(results, dropped, list(getattr(frames, "warnings", [])))


def family_priors(model: BimModel) -> dict[str, UprightPrior]:
    """The offline knowledge base's upright prior of each family of the model's movable elements (the demo's
    provider: verify and the demo's mission fit and judge with the same priors and symmetries)."""
    families = {el.family: el.ifc_class for el in movable_elements(model) if el.family}
    return KnowledgeBasePriors().priors(families, families)


def verify_frame(index: int, frame, model: BimModel, scene: OccludedMap, prior: np.ndarray | None,
                 config: VerifyConfig, priors: Mapping[str, UprightPrior] | None = None) -> FrameResult:
    """One frame or scan from ``prior`` (see :func:`verify_frames`); a frame's IMU ``up`` sets the prior's roll
    and pitch."""
    start = clock.perf_counter()
    points_sensor = sensor_points(frame)
    if isinstance(frame, Frame):
        name, when = frame.source, frame.time
        if prior is not None and frame.up is not None:
            prior = levelled(prior, frame.up)
    else:
        name, when = getattr(getattr(frame, "path", None), "name", None), None
    result = FrameResult(index, name or f"frame {index}", when, prior)
    if prior is None:
        result.reason = "no prior pose: give --prior X,Y,Z,YAW_DEG or --prior-file, or a source with poses"
        return _timed(result, start)
    try:
        scan = scan_points(_Cloud(points_sensor), config.localization)
    except LocalizationError as error:
        result.reason = str(error)
        return _timed(result, start)
    try:
        loc = localize_cloud(scan, model, prior, (0.0, 0.0, 1.0), config.localization)
    except LocalizationError as error:
        result.reason = str(error)
        result.depth = _depth_at_best_fit(scan, model, scene, prior, config)
        if result.depth is not None and result.depth.miscalibrated:
            result.reason += f"; at its best rigid fit {result.depth.reason} (or the prior is far off)"
        return _timed(result, start)
    result.pose, result.covariance, result.degenerate = loc.pose, loc.covariance, list(loc.degenerate)
    result.residual, result.inliers, result.accepted = loc.residual, loc.inliers, True
    result.depth = check_depth(scan, scene, loc.pose, config.localization.max_range, config.depth)
    result.observations, result.missing = _observe(index, points_sensor, loc.pose, model, scene, config,
                                                    priors)
    if result.depth.miscalibrated:
        reason = f"(sensor looks miscalibrated: {result.depth.reason})"
        result.observations = [replace(o, status=ElementStatus.UNVERIFIED, reason=reason) for o in result.observations]
        result.missing = []  # a bent depth sees past a place it merely misplaces
    return _timed(result, start)


def _depth_at_best_fit(scan, model: BimModel, scene: OccludedMap, prior: np.ndarray,
                       config: VerifyConfig) -> DepthCheck | None:
    """The depth check at the best rigid fit the localizer finds without its acceptance tests (three times the
    basin's reach, four times its turn, no inlier share, walls see-through): a frame refused because its depth is
    bent (office1 raw: its best rigid fit lies 0.34 m and 7.7 deg from the true pose) still says why. None when
    even that fit fails: then nothing says how the depth fits the BIM (RANSAC planes found without a fix ran
    through a far wall's depth steps, and were no test)."""
    loose = config.localization.model_copy(update={
        "max_correction": 3 * config.localization.max_correction,
        "max_correction_deg": 4 * config.localization.max_correction_deg, "min_inlier_fraction": 0.0,
        "min_inliers": 6, "max_behind_fraction": 1.0})
    try:
        best = localize_cloud(scan, model, prior, (0.0, 0.0, 1.0), loose)
    except LocalizationError:
        return None
    return check_depth(scan, scene, best.pose, config.localization.max_range, config.depth)


def sensor_points(frame) -> np.ndarray:
    """A frame's valid depth pixels, or a scan's finite points, in the sensor frame (N, 3), metres."""
    if isinstance(frame, Frame):
        return frame_points(frame)
    points = np.asarray(frame.points, dtype=np.float64)
    return points[np.all(np.isfinite(points), axis=1)] if points.ndim == 2 else points


def frame_points(frame: Frame) -> np.ndarray:
    """The frame's valid depth pixels as camera-frame points (N, 3), metres."""
    valid = frame.valid_depth
    v, u = np.nonzero(valid)
    depth = frame.depth[valid].astype(np.float64)
    return frame.intrinsics.backproject(np.stack([u, v], axis=1).astype(np.float64), depth)


@dataclass(frozen=True)
class _Cloud:
    points: np.ndarray


def _observe(index: int, points_sensor: np.ndarray, pose: np.ndarray, model: BimModel, scene: OccludedMap,
             config: VerifyConfig, priors: Mapping[str, UprightPrior] | None = None
             ) -> tuple[list[Observation], list[str]]:
    """The planned objects in view checked, and the new ones, from the fixed ``pose``; and the GlobalIds of the
    planned objects whose place the sensor saw empty."""
    points_sensor = points_sensor[:: max(1, len(points_sensor) // 90_000)]
    points_sensor = points_sensor[np.linalg.norm(points_sensor, axis=1) > 1e-6]
    located = points_sensor @ pose[:3, :3].T + pose[:3, 3]
    structure = structure_for(model)
    slab = structure.slab_height(pose[:3, 3])
    a, b = config.depth_noise
    ranges = np.linalg.norm(points_sensor, axis=1)
    directions = points_sensor / ranges[:, None]  # unit rays: a scan looks all round, no camera z to divide by
    building = explained(structure, pose[:3, 3], directions @ pose[:3, :3].T, ranges, config.surface_tolerance,
                         a + b * ranges**2, slab, config.surface_tolerance)
    left = located[~building]
    hits = scene.occluder_hits(pose, directions[:: max(1, len(directions) // 20_000)], 0.5,
                               config.localization.max_range)
    elements = planned_in_view(model, hits, config.planned)
    lookup = RangeLookup.of(points_sensor, pose)

    def behind_walls(points_world: np.ndarray) -> np.ndarray:
        offset = points_world - pose[:3, 3]
        distance = np.linalg.norm(offset, axis=1)
        return scene.permanent.first_hit(pose[:3, 3], offset / distance[:, None]) < distance - 0.03

    fits = check_planned(left, elements, model, slab, index, pose[:3, 3], behind_walls, lookup.seen_through,
                         config.planned, priors)
    # judged: a fit the twin will take (enough of its points on the body); the rest may have been seen empty
    judged = {f.element.global_id for f in fits if fit_trusted(f.observation.fitness, config.min_fitness)}
    empty = seen_empty([el for el in elements if el.global_id not in judged], model, pose[:3, 3], behind_walls,
                       lookup.compare, config.planned)
    gone = {el.global_id for el in empty}
    fits = [f for f in fits if f.element.global_id not in gone]
    observations = [f.observation for f in fits]
    if config.find_new:
        observations += new_objects(left, [(f.element.global_id, f.observation.pose) for f in fits], model, slab,
                                    index, config.new)
    return observations, [el.global_id for el in empty]


def _timed(result: FrameResult, start: float) -> FrameResult:
    result.seconds = clock.perf_counter() - start
    return result
