"""The robot mission: visit stations, capture RGB-D, perceive objects, register them with SG-ICP, decide what
changed against the BIM, and write the changes into the twin.

The steps, per the paper's loop (Fig. 1):
1. stations: one camera pose per object of interest, facing it from the site's interior, visited in a
   nearest-neighbour tour from the start;
2. capture: a frame per station (``capture(T_world_camera)``: the RGB-D simulator here, a robot driver on site);
3. perceive: detections (an ROI and a family label each) -> Shi-Tomasi corners in the ROI -> depth -> world points;
   a detection whose points lie on objects already registered is another view of them, not a new object;
4. associate: a detection belongs to the nearest unclaimed BIM element of its family within ``association_radius``;
   none means an object the BIM does not have;
5. register: SG-ICP from the BIM pose moved onto the detection (BIM yaw, the detection's centroid), with the
   family's upright prior;
6. decide: as planned / deviating (moved or turned) / new / unverified (fit too poor to trust), with
   translation, yaw and tilt deltas modulo the family's symmetry.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import trimesh

from bim2rdt.mission.association import associate
from bim2rdt.mission.config import MissionConfig
from bim2rdt.mission.fitting import best_fit, initial_poses, rests_on_slab
from bim2rdt.mission.ground import off_slab
from bim2rdt.mission.merging import RegisteredObject, repeated_view
from bim2rdt.mission.records import MissionResult, Observation, Target
from bim2rdt.mission.route import DirectRoute, Locate, Route
from bim2rdt.mission.verdict import judge
from bim2rdt.perception.detection import Detection
from bim2rdt.registration import IcpConfig, sample_model
from bim2rdt.semantics import UprightPrior


def run_mission(targets: Sequence[Target], stations: Sequence[np.ndarray],
                perceive: Callable[[int, np.ndarray], list[Detection]],
                priors: dict[str, UprightPrior], new_object_mesh: Callable[[str], trimesh.Trimesh],
                config: MissionConfig = MissionConfig(), icp: IcpConfig = IcpConfig(),
                tick: Callable[[], None] = lambda: None, route: Route = DirectRoute()) -> MissionResult:
    """Visit ``stations``; ``perceive(station_index, T_world_camera)`` returns that frame's detections. Each
    object is registered once, from its detection with the most points; a detection its registered neighbours
    already explain is another view of them (:mod:`bim2rdt.mission.merging`). Returns every verdict.
    ``route`` gets the robot to each station and hears what it saw (:mod:`bim2rdt.mission.route`)."""
    result = MissionResult(list(stations))

    def locate(detection: Detection) -> tuple[Observation, trimesh.Trimesh]:
        target = associate(detection, targets, set(), config)
        mesh = target.mesh_body if target else new_object_mesh(detection.family)
        return _observe(detection, target, mesh, priors, config, icp)[0], mesh

    detections = _capture(result, perceive, config, tick, route, locate)
    claimed: set[str] = set()
    registered: list[RegisteredObject] = []
    for detection in sorted(detections, key=lambda d: -len(d.points_world)):
        seen_before = repeated_view(detection, registered, config)
        if seen_before is not None:
            if seen_before.family == detection.family:
                seen_before.seen_from(detection.station)
            continue
        target = associate(detection, targets, claimed, config)
        mesh = target.mesh_body if target else new_object_mesh(detection.family)
        observation, model_pts = _observe(detection, target, mesh, priors, config, icp)
        registered.append(RegisteredObject.of(observation, model_pts))
        result.observations.append(observation)
    result.not_seen = [t.global_id for t in targets if t.global_id not in claimed]
    return result


def _capture(result: MissionResult, perceive: Callable[[int, np.ndarray], list[Detection]], config: MissionConfig,
             tick: Callable[[], None], route: Route, locate: Locate) -> list[Detection]:
    """Every reached station's detections with at least ``min_points`` points (fewer: the object is not seen
    there); ``result.stations`` keeps the poses the route actually took."""
    found = []
    for index, planned in enumerate(result.stations):
        T_world_camera = route.reach(index, planned, lambda T: _seen(perceive(index, T), config), locate)
        if T_world_camera is not None:
            result.stations[index] = T_world_camera
            seen = _seen(perceive(index, T_world_camera), config)
            route.seen(index, seen, locate)
            found += seen
        tick()
    return found


def _seen(detections: list[Detection], config: MissionConfig) -> list[Detection]:
    return [d for d in detections if len(d.points_world) >= config.min_points]


def _observe(detection: Detection, target: Target | None, mesh: trimesh.Trimesh, priors: dict[str, UprightPrior],
             config: MissionConfig, icp: IcpConfig) -> tuple[Observation, np.ndarray]:
    """Register one object and judge it; also returns the model's surface samples (body frame)."""
    prior = priors[detection.family]
    model_pts, model_normals = sample_model(mesh, icp.sample_count, seed=icp.seed)
    object_pts = off_slab(detection.points_world, config)
    fit = best_fit(model_pts, model_normals, object_pts, initial_poses(detection, target, model_pts, config),
                   prior, config, icp, local_first=target is not None,
                   support_height=config.slab_height if rests_on_slab(target, model_pts, config) else None)
    judged = judge(target, fit, prior.symmetry, config)
    observation = Observation(family=detection.family, global_id=target.global_id if target else None,
                              pose=fit.pose, rmse=fit.rmse, fitness=fit.fitness, points=len(object_pts),
                              station=detection.station, frames=(detection.station,), fit=fit,
                              status=judged.status, shift=judged.shift, yaw_deg=judged.yaw_deg,
                              tilt_deg=judged.tilt_deg, upright_bias=prior.upright_bias, reason=judged.reason)
    return observation, model_pts
