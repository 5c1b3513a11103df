"""The robot mission: visit stations, capture RGB-D, perceive objects, register them with SG-ICP, decide what
changed against the BIM, and write the changes into the twin.

The steps, per the paper's loop (Fig. 1):
1. stations: one camera pose per object of interest, facing it from the site's interior, visited in a
   nearest-neighbour tour from the start;
2. capture: a frame per station (``capture(T_world_camera)``: the RGB-D simulator here, a robot driver on site);
3. perceive: detections (an ROI and a family label each) -> Shi-Tomasi corners in the ROI -> depth -> world points;
4. associate: a detection belongs to the nearest unclaimed BIM element of its family within ``association_radius``;
   none means an object the BIM does not have;
5. register: SG-ICP from the BIM pose moved onto the detection (BIM yaw, the detection's centroid), with the
   family's upright prior;
6. decide: as planned / moved / new / unverified (fit too poor to trust), with translation, yaw and tilt deltas.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import trimesh
from pydantic import BaseModel, ConfigDict, Field

from bim2rdt.perception.camera import look_at
from bim2rdt.perception.slab import SLAB_CLEARANCE, off_the_slab
from bim2rdt.registration import IcpConfig, RegistrationResult, register, sample_model
from bim2rdt.semantics import UprightPrior
from bim2rdt.sim.truth import closest_equivalent

UP_WORLD = np.array([0.0, 0.0, 1.0])
SLAB_HEIGHT = 0.0
"""Height of the site's slab in the site frame, m (the embedded site's ground; ROI points near it are dropped)."""


class MissionConfig(BaseModel):
    """Knobs of one mission. Lengths in metres, angles in degrees."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    standoff: float = Field(2.6, gt=0.5, description="Camera distance from each object it is sent to look at.")
    camera_height: float = Field(1.1, gt=0.1, description="Camera height above the slab (quadruped with a mast).")
    min_points: int = Field(30, ge=6, description="Fewer ROI points than this and the object is 'not seen'.")
    slab_contact: float = Field(0.05, ge=0.0, description="A BIM element whose lowest point is this close to the "
                                                          "slab stands on it (registration pulls it onto the slab).")
    ground_clearance: float = Field(SLAB_CLEARANCE, ge=0.0, description="ROI points below this height are slab, not object.")
    association_radius: float = Field(1.5, gt=0.0, description="Farthest a detection may be from its BIM element.")
    moved_translation: float = Field(0.05, gt=0.0, description="A shift beyond this is a deviation.")
    moved_rotation_deg: float = Field(5.0, gt=0.0, description="A yaw or tilt change beyond this is a deviation.")
    min_fitness: float = Field(0.5, ge=0.0, le=1.0, description="Below this inlier fraction (of the points above the slab) the fit is unverified.")
    tie_ratio: float = Field(1.15, ge=1.0, description="A fit from the BIM pose within this factor of the best "
                                                        "score wins (the BIM is the prior).")
    model_samples: int = Field(10000, ge=6, description="Surface samples per model (see IcpConfig.sample_count).")


@dataclass(frozen=True)
class Target:
    """An object the mission looks for: a BIM element (GlobalId, family, placement, body mesh)."""

    global_id: str
    family: str
    placement: np.ndarray
    mesh_body: trimesh.Trimesh


@dataclass(frozen=True)
class Detection:
    """What perception hands the mission: a family label and the object's world points (N, 3) from one frame."""

    family: str
    points_world: np.ndarray
    station: int
    truth_index: int | None = None  # simulation only: which true object produced it, for scoring


@dataclass
class Observation:
    """One registered object and the mission's verdict on it."""

    family: str
    global_id: str | None
    status: str  # "as-planned" | "moved" | "new" | "unverified"
    pose: np.ndarray
    fit: RegistrationResult
    points: int
    station: int
    shift: float  # m, horizontal, against the BIM placement (0 for new objects)
    yaw_deg: float
    tilt_deg: float
    upright_bias: float
    truth_index: int | None = None


@dataclass
class MissionResult:
    """Stations (T_world_camera each), the observations, and the BIM targets never seen."""

    stations: list[np.ndarray]
    observations: list[Observation] = field(default_factory=list)
    not_seen: list[str] = field(default_factory=list)


def plan_stations(targets: Sequence[Target], start_xy: Sequence[float], config: MissionConfig) -> list[np.ndarray]:
    """One camera pose per target, in nearest-neighbour order from ``start_xy``. Each looks at its object
    obliquely across its long side (35 degrees off broadside: an end-on view of a beam cannot tell where along
    its length it lies), from the side facing the other targets, far enough back for the whole object."""
    centre = np.mean([t.placement[:2, 3] for t in targets], axis=0)
    poses = []
    for target in targets:
        where = target.placement[:2, 3]
        view = _view_direction(target, centre - where)
        standoff = max(config.standoff, 1.2 * float(np.max(target.mesh_body.extents[:2])))
        poses.append(look_at(np.r_[where + standoff * view, config.camera_height], np.r_[where, 0.35]))
    return _tour(poses, np.asarray(start_xy, dtype=float))


def _view_direction(target: Target, towards: np.ndarray) -> np.ndarray:
    """Unit (2,) direction from the object to its camera: broadside +-35 degrees, the one nearest ``towards``."""
    extents = target.mesh_body.extents
    long_axis = target.placement[:2, 0] if extents[0] >= extents[1] else target.placement[:2, 1]
    broadside = np.array([-long_axis[1], long_axis[0]]) / np.linalg.norm(long_axis)
    candidates = []
    for sign in (1.0, -1.0):
        for turn in np.deg2rad([35.0, -35.0]):
            c, s = np.cos(turn), np.sin(turn)
            candidates.append(sign * np.array([c * broadside[0] - s * broadside[1], s * broadside[0] + c * broadside[1]]))
    towards = towards / np.linalg.norm(towards) if np.linalg.norm(towards) > 1e-6 else np.array([0.0, -1.0])
    return max(candidates, key=lambda d: float(d @ towards))


def _tour(poses: list[np.ndarray], start_xy: np.ndarray) -> list[np.ndarray]:
    remaining, ordered, here = list(poses), [], start_xy
    while remaining:
        nearest = min(range(len(remaining)), key=lambda k: np.linalg.norm(remaining[k][:2, 3] - here))
        ordered.append(remaining.pop(nearest))
        here = ordered[-1][:2, 3]
    return ordered


def run_mission(targets: Sequence[Target], stations: Sequence[np.ndarray],
                perceive: Callable[[int, np.ndarray], list[Detection]],
                priors: dict[str, UprightPrior], new_object_mesh: Callable[[str], trimesh.Trimesh],
                config: MissionConfig = MissionConfig(), icp: IcpConfig = IcpConfig(),
                tick: Callable[[], None] = lambda: None) -> MissionResult:
    """Visit ``stations``; ``perceive(station_index, T_world_camera)`` returns that frame's detections. Each
    object is registered once, from the detection with the most points; returns every verdict."""
    result = MissionResult(list(stations))
    best: dict[object, Detection] = {}
    for index, T_world_camera in enumerate(stations):
        for detection in perceive(index, T_world_camera):
            if len(detection.points_world) >= config.min_points:
                key = detection.truth_index if detection.truth_index is not None else (index, id(detection))
                if key not in best or len(detection.points_world) > len(best[key].points_world):
                    best[key] = detection
        tick()
    claimed: set[str] = set()
    for detection in sorted(best.values(), key=lambda d: -len(d.points_world)):
        target = _associate(detection, targets, claimed, config)
        mesh = target.mesh_body if target else new_object_mesh(detection.family)
        result.observations.append(_observe(detection, target, mesh, priors, config, icp))
    result.not_seen = [t.global_id for t in targets if t.global_id not in claimed]
    return result


def _associate(detection: Detection, targets: Sequence[Target], claimed: set[str],
               config: MissionConfig) -> Target | None:
    centre = _object_centroid(detection.points_world, config)
    candidates = [t for t in targets if t.family == detection.family and t.global_id not in claimed]
    if not candidates:
        return None
    nearest = min(candidates, key=lambda t: np.linalg.norm(t.placement[:2, 3] - centre[:2]))
    if np.linalg.norm(nearest.placement[:2, 3] - centre[:2]) > config.association_radius:
        return None
    claimed.add(nearest.global_id)
    return nearest


def _observe(detection: Detection, target: Target | None, mesh: trimesh.Trimesh, priors: dict[str, UprightPrior],
             config: MissionConfig, icp: IcpConfig) -> Observation:
    prior = priors[detection.family]
    model_pts, model_normals = sample_model(mesh, config.model_samples, seed=icp.seed)
    object_pts = _off_the_slab(detection.points_world, config)
    fit = _best_fit(model_pts, model_normals, object_pts, _initial_poses(detection, target, model_pts, config),
                    prior, config, icp, local_first=target is not None,
                    support_height=SLAB_HEIGHT if _rests_on_slab(target, model_pts, config) else None)
    reference = target.placement if target else fit.pose
    shift, yaw, tilt = pose_delta(reference, closest_equivalent(detection.family, fit.pose, reference))
    return Observation(detection.family, target.global_id if target else None,
                       _status(target, fit, shift, yaw, tilt, config), fit.pose, fit, len(object_pts),
                       detection.station, shift, yaw, tilt, prior.upright_bias, detection.truth_index)


def _rests_on_slab(target: Target | None, model_pts: np.ndarray, config: MissionConfig) -> bool:
    """Whether the object stands on the slab: the BIM places its lowest point within ``slab_contact`` of it (a
    beam on trestles does not), and a new object found by the robot is taken to stand on it."""
    if target is None:
        return True
    lowest = float(np.min(model_pts @ target.placement[:3, :3].T[:, 2] + target.placement[2, 3]))
    return abs(lowest - SLAB_HEIGHT) <= config.slab_contact


def _best_fit(model_pts: np.ndarray, model_normals: np.ndarray, object_pts: np.ndarray, inits: list[np.ndarray],
              prior: UprightPrior, config: MissionConfig, icp: IcpConfig, local_first: bool,
              support_height: float | None = None) -> RegistrationResult:
    """Register from every start (yaw restarts each) and keep the lowest score. With ``local_first`` the first
    start (the BIM pose) is also refined without restarts, and that local fit wins any near-tie: when two yaws
    explain the points equally well (a tripod's three legs), the BIM's is the likelier."""
    def fit_from(init: np.ndarray, cfg: IcpConfig) -> RegistrationResult:
        return register(model_pts, model_normals, object_pts, init=init, up=UP_WORLD,
                        upright_bias=prior.upright_bias, yaw_only=prior.yaw_only, config=cfg,
                        support_height=support_height)

    best = min((fit_from(init, icp) for init in inits), key=lambda f: f.score)
    if not local_first:
        return best
    local = fit_from(inits[0], icp.model_copy(update={"restarts": 1, "yaw_jitter_deg": 0.0}))
    return local if local.score <= config.tie_ratio * best.score else best


def _off_the_slab(points_world: np.ndarray, config: MissionConfig, least: int | None = None) -> np.ndarray:
    """The ROI's points above the slab (the slab is in the BIM, so its corners are known clutter), or all of
    them when fewer than ``least`` (default ``config.min_points``) are above it."""
    return off_the_slab(points_world, slab_height=SLAB_HEIGHT, clearance=config.ground_clearance,
                        least=config.min_points if least is None else least)


def _initial_poses(detection: Detection, target: Target | None, model_pts: np.ndarray,
                   config: MissionConfig) -> list[np.ndarray]:
    """Where to start: the BIM pose as it is (most objects have not moved), and the BIM pose slid in the plane
    so the model's box centre stands on the detection's (for moved ones); a new object starts upright at zero
    yaw on the detection. The registration's yaw restarts cover the rest."""
    T = target.placement.copy() if target else np.eye(4)
    axes = T[:2, :2]  # the object's body x and y, in the world plane
    model_world = model_pts @ T[:3, :3].T + T[:3, 3]
    slid = T.copy()
    slid[:2, 3] += axes @ (_box_centre(detection.points_world, axes, config)
                           - _box_centre(model_world, axes, config))
    starts = [T, slid] if target else [slid]
    return starts + _along_long_axis(slid, model_pts)


def _along_long_axis(T: np.ndarray, model_pts: np.ndarray, slender: float = 3.0) -> list[np.ndarray]:
    """For a slender object (a beam, a pipe) also start a quarter length either way along its long axis:
    its sides are parallel to that axis, so only the ends pin where along it the object lies."""
    extents = np.ptp(model_pts[:, :2], axis=0)
    if extents.max() < slender * max(extents.min(), 1e-6):
        return []
    axis = T[:3, int(np.argmax(extents))] * 0.25 * extents.max()
    return [_shifted(T, axis), _shifted(T, -axis)]


def _shifted(T: np.ndarray, offset: np.ndarray) -> np.ndarray:
    out = T.copy()
    out[:3, 3] += offset
    return out


def _object_centroid(points_world: np.ndarray, config: MissionConfig) -> np.ndarray:
    """Median (3,) of the points above the slab: robust to the ROI's clutter, for association."""
    return np.median(_off_the_slab(points_world, config, least=1), axis=0)


def _box_centre(points_world: np.ndarray, axes: np.ndarray, config: MissionConfig) -> np.ndarray:
    """Centre (2,) of the points' 5-95 % extent along the body axes ``axes`` (columns). Extents, unlike a mean
    or median, are not pulled towards the near end, where perspective puts most of the corners."""
    along = _off_the_slab(points_world, config, least=1)[:, :2] @ axes
    low, high = np.percentile(along, [5.0, 95.0], axis=0)
    return (low + high) / 2


def pose_delta(T_ref: np.ndarray, T: np.ndarray) -> tuple[float, float, float]:
    """Horizontal shift (m), yaw change (deg, wrapped to +-180) and tilt of T's up axis from world z (deg)."""
    shift = float(np.linalg.norm(T[:2, 3] - T_ref[:2, 3]))
    yaw = np.rad2deg(np.arctan2(T[1, 0], T[0, 0]) - np.arctan2(T_ref[1, 0], T_ref[0, 0]))
    tilt = float(np.rad2deg(np.arccos(np.clip(T[2, 2], -1.0, 1.0))))
    return shift, float((yaw + 180.0) % 360.0 - 180.0), tilt


def _status(target: Target | None, fit: RegistrationResult, shift: float, yaw: float, tilt: float,
            config: MissionConfig) -> str:
    if fit.fitness < config.min_fitness:
        return "unverified"
    if target is None:
        return "new"
    deviated = (shift > config.moved_translation or abs(yaw) > config.moved_rotation_deg
                or tilt > config.moved_rotation_deg)
    return "moved" if deviated else "as-planned"
