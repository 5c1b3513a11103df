"""The perception front end, end to end: frame(s) -> detections -> corner points -> BIM element -> SG-ICP pose.

``perceive_frame`` runs one frame; ``perceive_frames`` runs several views of one place and fuses them: the
detections of one physical object (same family, same place; a tripod whose legs an image edge cut in two counts
once) are registered together, with the points of every view. Each object found becomes one
:class:`~bim2rdt.perception.observation.Observation`: the matched BIM element's GlobalId (the nearest
unclaimed element of its family within ``association_radius``, or None for an object the BIM lacks), its
registered pose, fit and where it was seen. Unusable detections (an ROI off the image, no valid depth) are
dropped with a one-line reason in the log; the frame itself is checked where it is built
(:class:`~bim2rdt.perception.frame.Frame`).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from bim2rdt.bim import BimModel
from bim2rdt.perception.background import BimStructure, structure_for
from bim2rdt.perception.detection import Detection
from bim2rdt.perception.detector import Detector
from bim2rdt.perception.edges import EdgeFilter
from bim2rdt.perception.errors import PerceptionError
from bim2rdt.perception.fitting import FitRules, fit_detection
from bim2rdt.perception.frame import Frame
from bim2rdt.perception.library import ModelLibrary, library_for
from bim2rdt.perception.observation import UNKNOWN_FAMILY, Observation
from bim2rdt.perception.points import detection_points
from bim2rdt.perception.visibility import DepthView, see_through_fraction
from bim2rdt.perception.slab import SLAB_CLEARANCE
from bim2rdt.perception.yoloe import yoloe_prompts
from bim2rdt.registration import IcpConfig
from bim2rdt.registration import MIN_SCENE_POINTS
from bim2rdt.semantics import UprightPrior

log = logging.getLogger(__name__)


class PerceiveConfig(BaseModel):
    """Knobs of the front end after the detector (lengths in metres)."""

    model_config = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)

    association_radius: float = 1.5
    """Farthest an object may be (in plan) from the BIM element it is matched to."""
    fuse_distance: float = 0.3
    """Two detections of one family whose poses (or, without poses, point medians) lie closer are one object."""
    min_points: int = 12
    """Fewer corner points with depth than this and the detection is dropped (its reason is logged)."""
    max_corners: int = 600
    mask_margin: int = 3
    """Corners are taken up to this many pixels outside a detection's mask (silhouette corners)."""
    mask_points: int = 300
    """Besides corners, this many depth pixels spread over a detection's mask (0 = corners only, the paper's
    way): corners crowd on edges and textured faces, and a view of one flat face (a pallet's deck from afar)
    leaves registration unable to tell where in that plane the object is."""
    slab_clearance: float = SLAB_CLEARANCE
    slab_contact: float = 0.05
    """An object whose BIM pose has its lowest point this close to the slab rests on it during registration."""
    model_samples: int = 10000
    max_see_through: float = 0.1
    """A fit is plausible when at most this fraction of its visible surface stands where a camera saw through
    (:mod:`bim2rdt.perception.visibility`: no drum seen from behind)."""
    tie_ratio: float = 1.15
    """The BIM pose wins when its fit's score is within this factor of the best (:mod:`~bim2rdt.perception.fitting`)."""
    icp: IcpConfig = Field(default_factory=IcpConfig)
    edge_filter: EdgeFilter = Field(default_factory=EdgeFilter)

    def fit_rules(self) -> FitRules:
        """The fitting path's rules for perception.

        Returns:
            Rules with this config's ICP settings, tie ratio and slab contact; a detector's pose came from its own
                search, so it is refined, not searched again (a frame's time budget: ``bench perception``).
        """
        return FitRules(self.icp, self.tie_ratio, self.slab_contact, refine_detector_pose=True)


@dataclass
class _Seen:
    """One usable detection with its points and the index of the frame it came from."""

    detection: Detection
    frame: int
    points: np.ndarray
    view: DepthView  # the frame's filtered depth, for free-space checks


def perceive_frame(frame: Frame, model: BimModel, priors: dict[str, UprightPrior], detector: Detector | None = None,
                   config: PerceiveConfig = PerceiveConfig()) -> list[Observation]:
    """Detect and register the objects in one frame.

    Args:
        frame: A localized RGB-D frame (``T_world_camera`` set; depth in metres).
        model: The BIM, loaded with geometry.
        priors: {family: upright prior} for the gravity term of registration.
        detector: The detector; None uses :class:`~bim2rdt.perception.geometric.GeometricDetector` on ``model``.
        config: Perception's thresholds.

    Returns:
        One :class:`Observation` per object: family, the matched GlobalId, ``pose`` (``T_world_object``, 4x4,
            metres), RMSE (metres) and fitness.

    Raises:
        PerceptionError: The frame is not a Frame or has no pose.
    """
    return perceive_frames([frame], model, priors, detector, config)


def perceive_frames(frames: Sequence[Frame], model: BimModel, priors: dict[str, UprightPrior],
                    detector: Detector | None = None, config: PerceiveConfig = PerceiveConfig()) -> list[Observation]:
    """Detect the objects in several views of one place and fuse them: one :class:`Observation` per physical
    object, its points from every view registered together.

    Args:
        frames: Localized RGB-D frames (``T_world_camera`` set; depth in metres).
        model: The BIM, loaded with geometry.
        priors: {family: upright prior} for the gravity term of registration.
        detector: The detector; None uses :class:`~bim2rdt.perception.geometric.GeometricDetector` on ``model``.
        config: Perception's thresholds.

    Returns:
        The observations, the best-supported object (most points) first.

    Raises:
        PerceptionError: An item is not a Frame, or a frame has no pose.
    """
    frames = list(frames)
    for frame in frames:
        if not isinstance(frame, Frame):
            raise PerceptionError(f"perceive: expected a Frame, got {type(frame).__name__}")
    detector = detector if detector is not None else _default_detector(model)
    library, structure = library_for(model), structure_for(model)
    seen = [item for index, frame in enumerate(frames)
            for item in _seen_in(frame, index, [_resolved(d, library) for d in detector.detect(frame)], structure,
                                 config)]
    groups = _fuse(seen, library, config)
    claimed: set[str] = set()
    slab = structure.slab_height(frames[0].T_world_camera[:3, 3]) if frames else 0.0
    return [_observe(group, library, priors, claimed, slab, config)
            for group in sorted(groups, key=lambda g: -sum(len(s.points) for s in g))]


def locate_detections(frame: Frame, model: BimModel, detector: Detector | None = None, station: int | None = None,
                      config: PerceiveConfig = PerceiveConfig()) -> list[Detection]:
    """The detector's detections in ``frame`` with their world points (``points_world``: corners and mask
    pixels with depth, flying pixels and the BIM's building removed) and ``station``; families resolved to the
    model's, unusable detections dropped with a logged reason. What a mission that registers objects itself
    needs from perception.

    Args:
        frame: A localized RGB-D frame (``T_world_camera`` set; depth in metres).
        model: The BIM, loaded with geometry.
        detector: The detector; None uses :class:`~bim2rdt.perception.geometric.GeometricDetector` on ``model``.
        station: The index of the station the frame was taken at, stored on each detection.
        config: Perception's thresholds.

    Returns:
        The usable detections with ``points_world`` ((N,3) world metres) and ``station`` set.

    Raises:
        PerceptionError: The frame has no pose.
    """
    detector = detector if detector is not None else _default_detector(model)
    library = library_for(model)
    detections = [_resolved(d, library) for d in detector.detect(frame)]
    return [replace(s.detection, points_world=s.points, station=station)
            for s in _seen_in(frame, 0, detections, structure_for(model), config)]


def _seen_in(frame: Frame, index: int, detections: list[Detection], structure: BimStructure,
             config: PerceiveConfig) -> list[_Seen]:
    depth = config.edge_filter.apply(frame.depth)
    slab = structure.slab_height(frame.require_pose("perception")[:3, 3])
    out = []
    for detection in detections:
        points, reason = (np.zeros((0, 3)), detection.reason) if detection.reason else detection_points(
            frame, depth, detection, structure, slab, config.slab_clearance, config.edge_filter,
            config.max_corners, config.mask_margin, config.mask_points)
        if reason is None and len(points) < max(config.min_points, MIN_SCENE_POINTS):
            reason = f"{detection.family}: {len(points)} corner points with depth, fewer than {config.min_points}"
        if reason is not None:
            log.warning("perception: frame %d: dropped a detection: %s", index, reason)
            continue
        out.append(_Seen(detection, index, points, DepthView(depth, frame.intrinsics, frame.T_world_camera)))
    return out


def _resolved(detection: Detection, library: ModelLibrary) -> Detection:
    """The detection with a family of the model: a detector that knows only its prompts ("a traffic cone on a
    construction site") is mapped back to the family whose prompt that is; anything else is unknown."""
    if detection.family in library.families or detection.family == UNKNOWN_FAMILY:
        return detection
    family = yoloe_prompts(library.families).get(detection.label or detection.family, UNKNOWN_FAMILY)
    return replace(detection, family=family)


def _fuse(seen: list[_Seen], library: ModelLibrary, config: PerceiveConfig) -> list[list[_Seen]]:
    """Groups of detections that show one object: same family, poses (or point medians) within
    ``fuse_distance`` (for a family, at least a third of its plan diagonal: a tripod cut in two by the image edge)."""
    groups: list[list[_Seen]] = []
    for item in sorted(seen, key=lambda s: -len(s.points)):
        radius = config.fuse_distance
        if item.detection.family in library.families:
            radius = max(radius, library.families[item.detection.family].footprint / 3)
        home = next((g for g in groups if g[0].detection.family == item.detection.family
                     and np.linalg.norm(_where(g[0])[:2] - _where(item)[:2]) < radius), None)
        if home is None:
            groups.append([item])
        else:
            home.append(item)
    return groups


def _where(item: _Seen) -> np.ndarray:
    return item.detection.pose[:3, 3] if item.detection.pose is not None else np.median(item.points, axis=0)


def _observe(group: list[_Seen], library: ModelLibrary, priors: dict[str, UprightPrior], claimed: set[str],
             slab: float, config: PerceiveConfig) -> Observation:
    best = group[0]
    points = np.vstack([s.points for s in group])
    family = best.detection.family
    frames = tuple(sorted({s.frame for s in group}))
    score = max(s.detection.score for s in group)
    base = dict(points=len(points), score=float(score), bbox=_bbox(best.detection), detector=best.detection.detector,
                frames=frames)
    if family not in library.families:
        pose = np.eye(4)
        pose[:3, 3] = np.median(points, axis=0)
        return Observation(UNKNOWN_FAMILY if family == UNKNOWN_FAMILY else family, None, pose, float("nan"), 0.0,
                           **base)
    element = _associate(group, family, library, claimed, config)
    model_pts, model_normals = library.families[family].samples(config.model_samples, seed=config.icp.seed)
    views = [s.view for s in {s.frame: s for s in group}.values()]

    def consistent(fit) -> bool:
        return all(see_through_fraction(fit.pose, model_pts, model_normals, view) <= config.max_see_through
                   for view in views)

    fit = fit_detection(model_pts, model_normals, points, element.placement if element is not None else None,
                        [s.detection.pose for s in group if s.detection.pose is not None], priors.get(family),
                        slab, config.fit_rules(), plausible=consistent)
    return Observation(family, element.global_id if element is not None else None, fit.pose, float(fit.rmse),
                       float(fit.fitness), fit=fit, **base)


def _associate(group: list[_Seen], family: str, library: ModelLibrary, claimed: set[str], config: PerceiveConfig):
    """The nearest unclaimed BIM element of ``family`` within ``association_radius`` (claimed from now on)."""
    where = _where(group[0])
    candidates = [el for el in library.near(where, config.association_radius)
                  if el.family == family and el.global_id not in claimed]
    if not candidates:
        return None
    claimed.add(candidates[0].global_id)
    return candidates[0]


def _bbox(detection: Detection) -> tuple[int, int, int, int] | None:
    return tuple(int(c) for c in detection.bbox) if detection.bbox is not None else None


_DETECTORS: dict[tuple[int, str], Detector] = {}


def _default_detector(model: BimModel) -> Detector:
    from bim2rdt.perception.geometric import GeometricDetector

    key = (id(model), model.digest)
    if key not in _DETECTORS:
        _DETECTORS.clear()
        _DETECTORS[key] = GeometricDetector(model)
    return _DETECTORS[key]
