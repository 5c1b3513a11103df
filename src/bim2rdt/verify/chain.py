"""``verify``: a real recording or scan checked against its BIM, frame by frame.

For each frame: its points (sensor frame) -> :func:`~bim2rdt.localization.localize_cloud` on the permanent
elements from the prior -> the depth check (:mod:`.depth_check`) -> the points the permanent structure does not
explain -> each planned object in view checked by its own body (:mod:`.planned`) -> what is left, clustered,
as new objects (:mod:`.new_objects`). Each planned object in view is judged by the one judge shared with the
mission (:func:`bim2rdt.twin.judge_evidence`), and then on all the frames that saw it (:mod:`.fusion`); new
clusters that are people or moved are transient (:mod:`.transient`). The observations are recorded into a twin
by the caller (:mod:`.outputs`). A frame whose fix is refused carries the reason; a frame whose depth looks
miscalibrated has its observations unverified, with the reason.
"""

from __future__ import annotations

import functools
import time as clock
from collections import Counter, deque
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from bim2rdt.bim import BimModel
from bim2rdt.localization import (GlobalSearchConfig, LocalizationConfig, LocalizationError, OccludedMap, Refusal,
                                  depth_points, load_lattices, localize_cloud, scan_points)
from bim2rdt.perception import Frame, Observation, explained, movable_elements, structure_for
from bim2rdt.registration import load_kernels
from bim2rdt.semantics import KnowledgeBasePriors, UprightPrior
from bim2rdt.sources import as_recording
from bim2rdt.twin import ElementStatus, JudgeConfig, TwinConfig
from bim2rdt.verify.depth_check import DepthCheck, DepthCheckConfig, check_depth
from bim2rdt.verify.errors import VerifyError
from bim2rdt.verify.faces import PlanarFacesConfig
from bim2rdt.verify.fusion import (ElementLook, FusedElement, FusionConfig, fuse_frames, horizontal_sigma,
                                   located_covariance)
from bim2rdt.verify.new_objects import NewCluster, NewObjectConfig, new_clusters
from bim2rdt.verify.planned import PlannedConfig, check_planned, look_at, owned_points, planned_in_view
from bim2rdt.verify.priors import heading_deg, levelled
from bim2rdt.verify.transient import RECENT_FRAMES, TransientConfig, mark_transient
from bim2rdt.verify.rays import RangeLookup
from bim2rdt.verify import shift_search
from bim2rdt.verify.timing import stage
from bim2rdt.verify.tracking import OWN_POSES, Tracker


REAL_SENSOR = {"inlier_distance": 0.05, "huber_delta": 0.025, "min_inlier_fraction": 0.3}
"""Localization settings for consumer RGB-D cameras and scanners at up to ~5 m: a Kinect's depth noise is ~3 cm at
4.7 m (structured light grows with z^2), so inliers reach 5 cm and the Huber scale 2.5 cm; a real room has its
furniture in front of half the walls, so 30 % of the points near the map suffice."""


def real_sensor_localization(base: LocalizationConfig | None = None) -> LocalizationConfig:
    """``base`` (``Settings.localization``) with the real sensor's values (:data:`REAL_SENSOR`) wherever it does
    not set them itself: what verify localizes with. The robot's own defaults suit a time-of-flight camera's
    millimetre noise; a value the user sets (``BIM2RDT_LOCALIZATION__INLIER_DISTANCE``) wins.

    Args:
        base: Localization settings; None: the defaults.

    Returns:
        The settings verify uses.
    """
    base = base or LocalizationConfig()
    unset = {name: value for name, value in REAL_SENSOR.items() if name not in base.model_fields_set}
    return base.model_copy(update=unset)


class VerifyConfig(BaseModel):
    """The knobs of verify (``Settings.verify``, ``BIM2RDT_VERIFY__*``). ``depth_noise`` (a, b): the sensor's depth
    sigma is a + b z^2 metres at depth z (Kinect v1, Khoshelham & Elberink 2012: ~1.4 mm/m^2), used where a point is
    judged on or off a wall."""

    model_config = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)

    localization: LocalizationConfig = Field(default_factory=real_sensor_localization)
    """Follows ``Settings.localization`` with the real sensor's defaults (:func:`real_sensor_localization`); set
    ``BIM2RDT_LOCALIZATION__*``, not this."""
    planned: PlannedConfig = Field(default_factory=PlannedConfig)
    """The planned-object check."""
    new: NewObjectConfig = Field(default_factory=NewObjectConfig)
    """The new-object clusters."""
    depth: DepthCheckConfig = Field(default_factory=DepthCheckConfig)
    """The miscalibration test."""
    depth_noise: tuple[float, float] = (0.002, 0.0015)
    """(a m, b 1/m): the depth sigma a + b z^2 at depth z."""
    surface_tolerance: float = 0.03
    """A point this close to a permanent surface (plus 3 sigma of depth noise) is the building's."""
    min_fitness: float = TwinConfig().min_fitness
    """A fit with less of its points on the body than this is no evidence the object is there: its place may be
    judged seen empty instead. Follows ``Settings.twin.min_fitness``."""
    find_new: bool = True
    """Cluster what neither the building nor a planned object explains into new objects."""
    judge: JudgeConfig = JudgeConfig()
    """The one judge's rules (:func:`bim2rdt.twin.judge_evidence`)."""
    fusion: FusionConfig = FusionConfig()
    """How an element's frames are combined (:mod:`.fusion`)."""
    transient: TransientConfig = TransientConfig()
    """What makes a cluster a person or a thing that moved (:mod:`.transient`)."""
    faces: PlanarFacesConfig = PlanarFacesConfig()
    """The BIM's planar faces the depth check compares (:mod:`.faces`)."""
    max_scan_points: int = Field(2_000_000, ge=100_000)
    """A scan with more returns than this is thinned evenly (every k-th return, in the scanner's order) before
    anything reads it: a terrestrial scan of 10-40 million returns says no more about a room at the fix's and the
    heat map's spacing, and would take gigabytes."""


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
    refusal: str = ""
    """What kind of refusal ``reason`` is (a :class:`~bim2rdt.localization.Refusal` value, or "no prior pose")."""
    depth: DepthCheck | None = None
    observations: list[Observation] = field(default_factory=list)
    missing: list[str] = field(default_factory=list)
    """GlobalIds of planned objects in view whose place the sensor saw empty."""
    degenerate_yaw: bool = False
    """The view cannot fix the heading either."""
    seconds: float = 0.0
    recorded: np.ndarray | None = None
    """The frame's own pose as the recording gave it (a bag's camera in its world frame), or None."""
    looks: list[ElementLook] = field(default_factory=list)
    """Each planned object in view as this frame saw it, with the judge's verdict on this frame alone."""
    clusters: list[NewCluster] = field(default_factory=list)
    """The new-object clusters of this frame (transient ones marked)."""
    located_covariance: np.ndarray | None = None
    """The fix's covariance (6, 6) with the odometry's information added: the recording's own motion from the
    last fix, which pins what the view leaves free (:func:`~bim2rdt.verify.fusion.located_covariance`)."""
    lookup: RangeLookup | None = field(default=None, repr=False)
    """The frame's returns by direction while the motion test needs them (a fix with no free direction only)."""

    @property
    def fix(self) -> str:
        """"full", "partial" (the view leaves a direction free: :attr:`free`) or "refused"."""
        if not self.accepted:
            return "refused"
        return "partial" if self.free else "full"

    @property
    def free(self) -> list[str]:
        """What the fix leaves free, in words: "x free", "y free", "z free", "free along 35 deg" (a horizontal
        direction off the axes: along the one wall the view pins), "yaw free"."""
        return free_directions(self.degenerate, self.degenerate_yaw)
    prior_source: str = ""
    """Where the prior came from: ``global``, ``tracked``, ``source`` or ``user`` (:mod:`.tracking`)."""
    candidates: list[dict] = field(default_factory=list)
    """The global search's candidates (JSON), when it ran for this frame."""
    places: int | None = None
    """How many places fit when the global search's places were carried to this frame (1: resolved), or None."""
    resolved_at: int | None = None
    """The frame index at which the carried places came down to one (this frame, or a later one for a frame held
    while ambiguous and verified from the resolved pose carried back), or None."""

    def to_dict(self) -> dict:
        """The frame's entry in localization.json.

        Returns:
            JSON-ready fields: poses and covariances as nested lists (metres, radians), ``fix`` (full, partial,
                refused) and ``free`` (the directions a partial fix leaves free, in words), ``reason`` when refused.
        """
        entry = {"source": self.source, "time": self.time, "fix": self.fix, "free": self.free,
                 "pose": None if self.pose is None else self.pose.tolist(),
                 "covariance": None if self.covariance is None else self.covariance.tolist(),
                 "degenerate": [np.asarray(d).tolist() for d in self.degenerate], "residual": self.residual,
                 "inliers": self.inliers, "accepted": self.accepted,
                 "prior": None if self.prior is None else self.prior.tolist(),
                 "depth_check": self.depth.to_dict() if self.depth else None, "missing": self.missing,
                 "judged": {look.global_id: {"status": _status(look.judgement.status), "reason": look.judgement.reason,
                                             "in_sight": look.place.in_sight, "through": look.place.through}
                            for look in self.looks},
                 "transient": [{"centre": [round(float(v), 3) for v in c.observation.pose[:3, 3]],
                                "reason": c.transient} for c in self.clusters if c.transient],
                 "seconds": round(self.seconds, 3), "prior_source": self.prior_source}
        if self.candidates:
            entry["candidates"] = self.candidates
        if self.places is not None:
            entry["places"] = self.places
        if self.resolved_at is not None:
            entry["resolved_at"] = self.resolved_at
        if not self.accepted:
            entry["reason"], entry["refusal"] = self.reason, self.refusal
        return entry


def free_directions(degenerate: list, yaw: bool = False) -> list[str]:
    """The free directions of a fix in words: a unit world direction within 15 deg of an axis is "x free", "y
    free" or "z free"; another horizontal one "free along H deg" (its heading from +x: along the wall the view
    pins, in 0-180); any other "free along (dx, dy, dz)"; a free heading adds "yaw free".

    Args:
        degenerate: Unit world directions (3,) the view cannot fix.
        yaw: The heading is free too.

    Returns:
        One phrase per free direction.
    """
    words = []
    for direction in degenerate:
        d = np.asarray(direction, dtype=float)
        axis = int(np.argmax(np.abs(d)))
        if abs(d[axis]) >= np.cos(np.deg2rad(15.0)):
            words.append(f"{'xyz'[axis]} free")
        elif abs(d[2]) < np.sin(np.deg2rad(15.0)):
            words.append(f"free along {np.rad2deg(np.arctan2(d[1], d[0])) % 180:.0f} deg")
        else:
            words.append(f"free along ({d[0]:.2f}, {d[1]:.2f}, {d[2]:.2f})")
    return words + (["yaw free"] if yaw else [])


@dataclass
class VerifyResult:
    """Every frame's result in source order."""

    frames: list[FrameResult]
    dropped: list[dict] = field(default_factory=list)
    """Frames the source dropped before verify saw them (a bag's: no depth partner, no TF within the tolerance),
    each ``{"time", "reason", "kind"}``."""
    source_warnings: list[str] = field(default_factory=list)
    """What the source found off about the recording as a whole (a bag whose clocks disagree)."""
    elements: list[FusedElement] = field(default_factory=list)
    """Each planned object in view of any accepted frame, judged on all of them (:mod:`.fusion`)."""
    new: list[NewCluster] = field(default_factory=list)
    """The new objects: clusters of all frames merged, transient ones left out."""
    transient: list[NewCluster] = field(default_factory=list)
    """Clusters that are people or moved between frames: recorded here, never as new objects."""

    @property
    def drop_counts(self) -> dict[str, int]:
        """{kind (or reason): number} of the frames the source dropped."""
        return dict(Counter(d["kind"] for d in self.dropped))

    @property
    def localized(self) -> int:
        """Frames whose fix was accepted (full or partial)."""
        return sum(f.accepted for f in self.frames)

    @property
    def why_none_localized(self) -> str:
        """When no frame was localized, why, in one line: the commonest refusals with their counts; else ""."""
        if self.localized:
            return ""
        kinds = Counter(f.refusal for f in self.frames)
        top = ", ".join(f"{n} {kind}" for kind, n in kinds.most_common(3))
        return f"no frame localized ({top}); frame {self.frames[0].index}: {self.frames[0].reason}"

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
                  priors: Mapping[str, UprightPrior] | None = None,
                  look: Callable[[object, FrameResult, np.ndarray], None] | None = None, storey: str | None = None,
                  own_poses: str = "world") -> VerifyResult:
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
      tracked. An ambiguous view's places are carried through the next frames by their odometry (ICP between
      frames) until one is left; the frames seen meanwhile (at most eight) are then verified from the resolved
      pose carried back (``places``, ``resolved_at``). A view still ambiguous is refused ("ambiguous: N places
      fit") with every candidate listed. Each result's ``prior_source`` says which (:mod:`.tracking`);
    - with ``own_poses="odometry"`` and no ``prior``: the frames' own poses are in a frame never aligned to the
      model (a robot's ``map`` or ``odom``): they are only odometry, the first frame is searched globally and
      its places carried through the sweep by the own poses' steps, as above.

    What a :class:`~bim2rdt.sources.Recording` dropped (``{"time", "reason", "kind"}``, read after iterating) and
    its warnings about the recording are carried into the result (a plain iterable drops nothing).

    Args:
        frames: The frames or scans, in the order they were taken (a ``Recording``, or any iterable).
        model: The BIM, loaded with geometry.
        prior: ``T_world_sensor`` (4x4, metres) of the first frame in the model's frame; None trusts the
            frames' own poses until a fix is accepted, or searches the BIM when they have none.
        config: Localization, depth check and perception settings.
        progress: Called with each frame's result as it is done.
        priors: Family -> upright prior, to fit each planned object as the mission fits it (default:
            :func:`family_priors` of ``model``).
        look: Called with each frame (or scan), its result and its :func:`sensor_points` while the frame is at
            hand (the structure judge and the deviation maps, :mod:`.structure_run`).
        storey: The storey (name or GlobalId) a global search looks in; None searches every storey.
        own_poses: ``"world"``: the frames' own poses are in the model's frame until a fix is accepted;
            ``"odometry"``: they are odometry only (see above).

    Returns:
        Every frame's result in source order, with what the source dropped and warned about.

    Raises:
        VerifyError: The source holds no frames, the model has nothing to localize on, or ``own_poses`` is
            neither "world" nor "odometry".
    """
    if own_poses not in OWN_POSES:
        raise VerifyError(f"own poses must be one of {', '.join(OWN_POSES)}, not {own_poses!r}")
    try:
        with stage("setup"):
            scene = OccludedMap.of(model)
            load_kernels()  # numba's import and machine code (~0.4 s once), here and not in the first frame
            shift_search.load_kernels()  # the plan search's count, likewise
            load_lattices(config.localization, VIEW_RAY_DEG)  # the view's ray lattices: constants of the settings
    except LocalizationError as error:
        raise VerifyError(str(error)) from None
    priors = family_priors(model) if priors is None else priors
    results: list[FrameResult] = []
    anchor: tuple[np.ndarray | None, np.ndarray] | None = None if prior is None else (None, np.asarray(prior))
    anchor_covariance = None  # the located covariance of the fix the anchor is (None: the user's prior)
    recent: deque = deque(maxlen=RECENT_FRAMES)  # the frames a cluster is tested for motion against
    recording = as_recording(frames)
    tracker = Tracker(model, prior, GlobalSearchConfig(fix=config.localization), storey, own_poses)

    def verified(index: int, frame, points_sensor: np.ndarray, guess) -> None:
        nonlocal anchor, anchor_covariance
        own = frame.T_world_camera if isinstance(frame, Frame) else None
        result = verify_frame(index, frame, model, scene, guess.pose, config, priors, points_sensor)
        result.recorded = own
        result.prior_source, result.candidates = guess.source, guess.candidates
        result.places, result.resolved_at = guess.places, guess.resolved_at
        if guess.pose is None and guess.reason:
            result.reason = guess.reason
        tracker.update(guess, result.pose, result.accepted)
        if result.accepted:
            result.located_covariance = located_covariance(result.covariance, anchor, anchor_covariance, own,
                                                           config.fusion)
            anchor_covariance = result.located_covariance
        mark_transient(result, recent, config.transient)
        if not result.accepted:
            result.lookup = None
        if result.accepted and (anchor is not None or own is not None):
            anchor = (own, result.pose)
        elif anchor is not None and anchor[0] is None and own is not None:
            anchor = (own, anchor[1])  # the user's prior is where the sensor was at its first pose
        results.append(result)
        if look is not None:
            look(frame, result, points_sensor)
        if progress is not None:
            progress(result)

    thinned: list[str] = []
    for frame in recording:
        points_sensor = sensor_points(frame, config.max_scan_points)  # once: the tracker and the fix share them
        if not isinstance(frame, Frame) and len(frame.points) > config.max_scan_points:
            thinned.append(f"{getattr(getattr(frame, 'path', None), 'name', 'a scan')}: {len(frame.points):,} "
                           f"returns thinned evenly to {len(points_sensor):,} (verify.max_scan_points)")
        for ready in tracker.push(frame, points_sensor):
            verified(*ready)
    for ready in tracker.flush():
        verified(*ready)
    dropped = list(recording.dropped)
    if not results:
        reasons = "; ".join(f"{n} {k}" for k, n in Counter(d["reason"] for d in dropped).most_common(3))
        raise VerifyError("the source holds no frames" + (f" (all {len(dropped)} dropped: {reasons})" if dropped
                                                          else ""))
    verified = VerifyResult(results, dropped, list(recording.warnings) + thinned)
    verified.elements, verified.new, verified.transient = fuse_frames(results, config.min_fitness, config.fusion,
                                                                      config.judge)
    return verified


def _status(status: ElementStatus | None) -> str:
    return "by pose" if status is None else status.value


def family_priors(model: BimModel) -> dict[str, UprightPrior]:
    """The offline knowledge base's upright prior of each family of the model's movable elements (the demo's
    provider: verify and the demo's mission fit and judge with the same priors and symmetries)."""
    families = {el.family: el.ifc_class for el in movable_elements(model) if el.family}
    return _knowledge_base().priors(families, families)


@functools.cache
def _knowledge_base() -> KnowledgeBasePriors:
    """The curated knowledge base, built once per process (tokenising its synonyms costs ~0.2 s; verify and its
    twin both ask); read-only once built."""
    return KnowledgeBasePriors()


def verify_frame(index: int, frame, model: BimModel, scene: OccludedMap, prior: np.ndarray | None,
                 config: VerifyConfig, priors: Mapping[str, UprightPrior] | None = None,
                 points_sensor: np.ndarray | None = None) -> FrameResult:
    """One frame or scan from ``prior`` (see :func:`verify_frames`); a frame's IMU ``up`` sets the prior's roll
    and pitch. ``points_sensor``: its :func:`sensor_points`, when the caller has them already."""
    start = clock.perf_counter()
    points_sensor = sensor_points(frame) if points_sensor is None else points_sensor
    if isinstance(frame, Frame):
        name, when = frame.source, frame.time
        if prior is not None and frame.up is not None:
            prior = levelled(prior, frame.up)
    else:
        name, when = getattr(getattr(frame, "path", None), "name", None), None
    result = FrameResult(index, name or f"frame {index}", when, prior)
    if prior is None:
        result.reason = "no prior pose: give --prior X,Y,Z,YAW_DEG or --prior-file, or a source with poses"
        result.refusal = "no prior pose"
        return _timed(result, start)
    try:
        with stage("localize"):
            scan = scan_points(points_sensor, config.localization)
    except LocalizationError as error:
        result.reason, result.refusal = str(error), error.kind.value
        return _timed(result, start)
    try:
        with stage("localize"):
            loc = localize_cloud(scan, model, prior, (0.0, 0.0, 1.0), config.localization, scene)
    except LocalizationError as error:
        result.reason = str(error) + prior_hint(model, prior, always=error.kind is Refusal.NO_PERMANENT_IN_VIEW)
        result.refusal = error.kind.value
        with stage("depth check"):
            result.depth = _depth_at_best_fit(scan, model, scene, prior, config)
        if result.depth is not None and result.depth.miscalibrated:
            result.reason += f"; at its best rigid fit {result.depth.reason} (or the prior is far off)"
        return _timed(result, start)
    result.pose, result.covariance, result.degenerate = loc.pose, loc.covariance, list(loc.degenerate)
    result.degenerate_yaw = loc.degenerate_yaw
    result.residual, result.inliers, result.accepted = loc.residual, loc.inliers, True
    with stage("depth check"):
        result.depth = check_depth(scan, scene, loc.pose, config.localization.max_range, config.depth, config.faces)
    with stage("objects"):
        _observe(result, points_sensor, loc.pose, model, scene, config, priors)
    if result.depth.miscalibrated:
        _distrust(result, f"(sensor looks miscalibrated: {result.depth.reason})")
    return _timed(result, start)


VIEW_RAY_DEG = 0.5
"""Degrees between the rays that find which planned objects a frame could see (:meth:`OccludedMap.occluder_hits`)."""


LOW_PRIOR_M = 0.2
"""A prior this close to the slab under it is at floor height: a sensor is carried higher (hinted on any refusal)."""


def prior_hint(model: BimModel, prior: np.ndarray, always: bool = True) -> str:
    """What to check of a prior the fix failed from: its height above the slab under it and its heading in
    degrees (a prior at floor height, or a yaw given in radians, sees nothing of the map).

    Args:
        model: The BIM.
        prior: 4x4 T_world_sensor prior.
        always: Hint even when the prior's height looks plausible (the sensor saw no permanent element).

    Returns:
        "; check the prior: ..." to append to the refusal, or "" when not ``always`` and the height is plausible.
    """
    position = prior[:3, 3]
    slab = structure_for(model).slab_height(position)
    if not (always or position[2] - slab < LOW_PRIOR_M):
        return ""
    return (f"; check the prior: it puts the sensor {position[2] - slab:.2f} m above the floor under it and heads "
            f"it {heading_deg(prior):.0f} deg from +x "
            "(--prior takes X,Y,Z in the model's metres and the yaw in degrees, not radians)")


def _distrust(result: FrameResult, reason: str) -> None:
    """Every verdict of ``result`` unverified with ``reason``: a bent depth sees past a place it merely
    misplaces, and carries the bend into every fit; its clusters are no new objects."""
    result.observations = [replace(o, status=ElementStatus.UNVERIFIED, reason=reason) for o in result.observations]
    result.missing = []
    result.looks = [replace(look, judgement=replace(look.judgement, status=ElementStatus.UNVERIFIED, reason=reason),
                            observation=None if look.observation is None else
                            replace(look.observation, status=ElementStatus.UNVERIFIED, reason=reason))
                    for look in result.looks]
    result.clusters = []


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
        best = localize_cloud(scan, model, prior, (0.0, 0.0, 1.0), loose, scene)
    except LocalizationError:
        return None
    return check_depth(scan, scene, best.pose, config.localization.max_range, config.depth, config.faces)


def sensor_points(frame, max_scan_points: int | None = None) -> np.ndarray:
    """A frame's valid depth pixels, or a scan's finite points, in the sensor frame (N, 3), metres.

    Args:
        frame: A :class:`~bim2rdt.perception.Frame` or a cloud (``points``).
        max_scan_points: A scan with more finite points than this keeps every k-th of them (k the least that
            keeps at most this many); None keeps all. A frame's pixels are always all kept.

    Returns:
        The points.
    """
    if isinstance(frame, Frame):
        return depth_points(frame)
    points = np.asarray(frame.points)
    if points.ndim != 2:
        return np.asarray(points, dtype=np.float64)
    if max_scan_points is not None and len(points) > max_scan_points:
        points = points[:: -(-len(points) // max_scan_points)]  # before the float64 copy: a view, no memory
    points = np.asarray(points, dtype=np.float64)
    return points[np.all(np.isfinite(points), axis=1)]


def _observe(result: FrameResult, points_sensor: np.ndarray, pose: np.ndarray, model: BimModel,
             scene: OccludedMap, config: VerifyConfig, priors: Mapping[str, UprightPrior] | None = None) -> None:
    """The planned objects in view checked and judged (:func:`bim2rdt.twin.judge_evidence` on this frame), and
    the new clusters, from the fixed ``pose``: into ``result`` (its looks, observations, missing, clusters)."""
    points_sensor = points_sensor[:: max(1, len(points_sensor) // 90_000)]
    ranges = np.linalg.norm(points_sensor, axis=1)  # once: the kept rows' lengths are the same floats
    keep = ranges > 1e-6
    points_sensor, ranges = points_sensor[keep], ranges[keep]  # a contiguous copy, as BLAS's product had it
    located = points_sensor @ pose[:3, :3].T + pose[:3, 3]
    structure = structure_for(model)
    slab = structure.slab_height(pose[:3, 3])
    a, b = config.depth_noise
    directions = points_sensor / ranges[:, None]  # unit rays: a scan looks all round, no camera z to divide by
    building = explained(structure, pose[:3, 3], directions @ pose[:3, :3].T, ranges, config.surface_tolerance,
                         a + b * ranges**2, slab, config.surface_tolerance)
    left = located[~building]
    hits = scene.occluder_hits(pose, directions[:: max(1, len(directions) // 20_000)], VIEW_RAY_DEG,
                               config.localization.max_range)
    elements = planned_in_view(model, hits, config.planned)
    lookup = RangeLookup.of(points_sensor, pose)
    result.lookup = lookup if horizontal_sigma(result.covariance) <= config.fusion.max_sigma else None

    def behind_walls(points_world: np.ndarray) -> np.ndarray:
        offset = points_world - pose[:3, 3]
        distance = np.linalg.norm(offset, axis=1)
        return scene.permanent.first_hit(pose[:3, 3], offset / distance[:, None]) < distance - 0.03

    fits = {f.element.global_id: f for f in check_planned(left, elements, model, slab, result.index, pose[:3, 3],
                                                           behind_walls, lookup.seen_through, config.planned,
                                                           priors)}
    kept = []
    for element in elements:
        look = look_at(element, fits.get(element.global_id), model, pose[:3, 3], behind_walls, lookup.compare,
                       result.index, config.planned, config.judge, config.min_fitness)
        result.looks.append(look)
        if look.judgement.status is ElementStatus.MISSING:
            result.missing.append(element.global_id)
        elif look.observation is not None:
            result.observations.append(look.observation)
            kept.append((element.global_id, look.observation.pose))
    if config.find_new:
        unsure = [el for el, look in zip(elements, result.looks) if look.judgement.status is ElementStatus.UNVERIFIED]
        if unsure and len(left):  # what the plan gives an object it could not judge is that object's, not new
            left = left[owned_points(left, unsure, model, config.planned) < 0]
        result.clusters = new_clusters(left, kept, model, slab, result.index, config.new)
        result.observations += [c.observation for c in result.clusters]


def _timed(result: FrameResult, start: float) -> FrameResult:
    result.seconds = clock.perf_counter() - start
    return result
