"""The robot mission: visit stations, capture RGB-D, perceive objects, register them with SG-ICP, decide what
changed against the BIM, and write the changes into the twin.

The steps, per the paper's loop (Fig. 1):
1. stations: one camera pose per object of interest, facing it from the site's interior, visited in a
   nearest-neighbour tour from the start;
2. capture: a frame per station (``capture(T_world_camera)``: the RGB-D simulator here, a robot driver on site);
3. perceive: detections (an ROI and a family label each) -> Shi-Tomasi corners in the ROI -> depth -> world points;
   a detection whose points lie on objects already registered is another view of them, not a new object;
4. associate: a detection belongs to the BIM element of its family the frame's joint assignment gives it, else
   the nearest unclaimed one within ``association_radius``; none means an object the BIM does not have;
5. register: SG-ICP from the BIM pose moved onto the detection (BIM yaw, the detection's centroid), with the
   family's upright prior;
6. decide: as planned / deviating (moved or turned) / new / unverified (fit too poor to trust), with
   translation, yaw and tilt deltas modulo the family's symmetry;
7. absence: a planned element no detection claimed, whose place a station's frame shows empty (the camera saw
   through it: :mod:`bim2rdt.mission.absence`), is missing; one never in view, or occluded, stays not seen.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable, Sequence

import numpy as np
import trimesh

from bim2rdt.mission.absence import depth_view, seen_empty
from bim2rdt.mission.association import associate, preferred_targets
from bim2rdt.mission.config import MissionConfig
from bim2rdt.mission.context import MissionContext
from bim2rdt.mission.explained import Explanation, KnownSurface, explaining_surface, fit_inliers
from bim2rdt.mission.fitting import fit_target
from bim2rdt.mission.ground import object_points
from bim2rdt.mission.merging import RegisteredObject, repeated_view
from bim2rdt.mission.records import MissionResult, Observation, Target
from bim2rdt.mission.route import DirectRoute, Locate, Route
from bim2rdt.mission.verdict import judge, tolerance_of
from bim2rdt.perception import Detection, Frame
from bim2rdt.perception import DepthView, see_through_fraction
from bim2rdt.registration import IcpConfig, RegistrationResult, sample_model
from bim2rdt.twin import ElementStatus, FitEvidence, judge_evidence

log = logging.getLogger(__name__)


def run_mission(context: MissionContext, perceive: Callable[[int, np.ndarray], list[Detection]],
                route: Route = DirectRoute(), frame_of: Callable[[int], Frame | None] | None = None) -> MissionResult:
    """Visit the ``context``'s stations to see its targets (:class:`~bim2rdt.mission.context.MissionContext`:
    also the priors, the mesh of a new object, the settings and ``tick``, called after each station);
    ``perceive(station_index, T_world_camera)`` returns that frame's detections. Each object is registered once, from its detection with the most points; a detection its registered neighbours
    already explain is another view of them (:mod:`bim2rdt.mission.merging`). Returns every verdict.
    ``route`` gets the robot to each station and hears what it saw (:mod:`bim2rdt.mission.route`).
    ``frame_of(station_index)``, when given, is the frame (depth, intrinsics, camera pose) the station's
    detections were read from: with it, a planned element whose place a frame shows empty is missing.
    The context's ``tolerances`` judge as planned vs deviating (the twin's presets: pass
    ``Settings.twin.tolerance_policy()`` so the mission and the twin agree; default ``TwinConfig()``'s), and its
    ``min_fitness`` whether a fit can be judged at all (``Settings.twin.min_fitness``). Its ``building`` holds the
    surfaces of the BIM's permanent elements (:func:`bim2rdt.mission.explained.building_surfaces`): a fit whose points lie on one of
    them, or on an object registered before it, shows that surface, not an object
    (:mod:`bim2rdt.mission.explained`): a planned element's fit is then unverified, and a detection of no planned
    element is ``set_aside`` (no new object); such a fit explains nothing for the detections after it.

    Args:
        context: The mission: targets, stations (``T_world_camera``), model, priors and settings.
        perceive: ``perceive(station_index, T_world_camera)`` returns that frame's detections with world points.
        route: Gets the robot to each station and hears what it saw.
        frame_of: ``frame_of(station_index)`` is the frame the station's detections were read from; None
            finds no element missing.

    Returns:
        Every verdict: the stations, the observations, the missing, the not-seen and the set-aside objects.
    """
    context = context.with_building()
    targets, config, icp, new_object_mesh = context.targets, context.config, context.icp, context.new_object_mesh
    result = MissionResult(list(context.stations))
    views: dict[int, DepthView] = {}

    def locate(detection: Detection) -> tuple[Observation, trimesh.Trimesh]:
        target = associate(detection, targets, set(), config)
        mesh = target.mesh_body if target else new_object_mesh(detection.family)
        return _observe(detection, target, mesh, context)[0], mesh

    detections = _capture(result, perceive, config, context.tick, route, locate, frame_of, views)
    claimed: set[str] = set()
    preferred = preferred_targets(detections, targets, config)
    registered: list[RegisteredObject] = []
    known = list(context.building)
    for detection, choice in sorted(zip(detections, preferred), key=lambda seen: -len(seen[0].points_world)):
        seen_before = repeated_view(detection, registered, config)
        if seen_before is not None:
            if seen_before.family == detection.family:
                seen_before.seen_from(detection.station)
            continue
        target = associate(detection, targets, claimed, config, choice)
        if target is not None:
            claimed.add(target.global_id)
        mesh = target.mesh_body if target else new_object_mesh(detection.family)
        observation, model_pts, owner = _observe(detection, target, mesh, context, views.get(detection.station),
                                                 known)
        if owner is not None and target is None:  # a known surface, not an object the BIM lacks
            result.set_aside.append(observation)
            continue
        result.observations.append(observation)
        if owner is None:  # a fit of another element's surface is no object: it explains nothing after it
            registered.append(RegisteredObject.of(observation, model_pts))
            known.append(KnownSurface.of_mesh(_registered_name(observation), mesh, observation.pose))
    unclaimed = [t for t in targets if t.global_id not in claimed]
    result.missing = [gone for gone in (seen_empty(t, views, config, icp) for t in unclaimed) if gone is not None]
    gone_ids = {gone.global_id for gone in result.missing}
    result.not_seen = [t.global_id for t in unclaimed if t.global_id not in gone_ids]
    return result


def _capture(result: MissionResult, perceive: Callable[[int, np.ndarray], list[Detection]], config: MissionConfig,
             tick: Callable[[], None], route: Route, locate: Locate, frame_of: Callable[[int], Frame | None] | None,
             views: dict[int, DepthView]) -> list[Detection]:
    """Every reached station's detections with at least ``min_points`` points (fewer: the object is not seen
    there); ``result.stations`` keeps the poses the route actually took, ``views`` each reached station's depth
    (with ``frame_of``)."""
    found = []
    for index, planned in enumerate(result.stations):
        T_world_camera = route.reach(index, planned, lambda T: _seen(perceive(index, T), config), locate)
        if T_world_camera is not None:
            result.stations[index] = T_world_camera
            seen = _seen(perceive(index, T_world_camera), config)
            frame = frame_of(index) if frame_of is not None else None
            if frame is not None:
                views[index] = depth_view(frame)
            route.seen(index, seen, locate)
            found += seen
        tick()
    return found


def _free_space(model_pts: np.ndarray, model_normals: np.ndarray, view: DepthView | None,
                config: MissionConfig) -> Callable[[RegistrationResult], bool]:
    """The free-space test of a fit in ``view`` (every fit passes without a view)."""
    if view is None:
        return lambda fit: True
    return lambda fit: see_through_fraction(fit.pose, model_pts, model_normals, view) <= config.max_see_through


def _seen(detections: list[Detection], config: MissionConfig) -> list[Detection]:
    return [d for d in detections if len(d.points_world) >= config.min_points]


def _observe(detection: Detection, target: Target | None, mesh: trimesh.Trimesh, context: MissionContext,
             view: DepthView | None = None,
             known: Sequence[KnownSurface] = ()) -> tuple[Observation, np.ndarray, Explanation | None]:
    """Register one object and judge it (against its tolerance preset under the context's ``tolerances``, and
    its ``min_fitness``); also returns the model's surface samples (body frame) and, when at least
    ``explained_fraction`` of the fit's inliers lie on one of the ``known`` surfaces, that surface: the fit is then unverified. With ``view`` (the depth of the
    detection's station) a fit that stands where the camera saw through is set aside for a consistent one."""
    config, icp = context.config, context.icp
    prior = context.priors[detection.family]
    model_pts, model_normals = sample_model(mesh, icp.sample_count, seed=icp.seed)
    object_pts = object_points(detection.points_world, config)
    fit = fit_target(detection, target, model_pts, model_normals, object_pts, prior, config, icp,
                     _free_space(model_pts, model_normals, view, config))
    judged = judge(target, fit, prior.symmetry, config, tolerance_of(target, context.tolerances) if target else None,
                   context.min_fitness)
    reason = judged.reason  # the verdict's own: too few points explained, or a direction the view cannot see
    if not math.isfinite(fit.rmse):  # a partial view behind a wall: no point lies on the fitted model
        reason = (f"(no inlier: none of its {len(object_pts)} points lies within {100 * icp.score_distance:.0f} cm "
                  "of the fitted model)")
    elif view is not None and (seen_through := see_through_fraction(fit.pose, model_pts, model_normals, view)) \
            > config.max_see_through:  # every start ended where the camera saw through
        reason = f"(the fit stands where the camera saw through, at {seen_through:.0%} of its visible surface)"
    owner = _explained_by(object_pts, mesh, fit, known, config, icp)
    if owner is not None:  # the points are another element's: the fit shows that element, not this object
        reason = owner.reason()
    if reason:  # the one judge (shared with verify): a fit its observer distrusts is unverified, with why
        trust = judge_evidence(None, FitEvidence(fit.fitness, reason), context.min_fitness)
        judged = dataclasses.replace(judged, status=trust.status)
        log.info("%s at station %s: unverified %s", detection.family, detection.station, reason)
    observation = Observation(family=detection.family, global_id=target.global_id if target else None,
                              pose=fit.pose, rmse=fit.rmse, fitness=fit.fitness, points=len(object_pts),
                              station=detection.station, frames=(detection.station,), fit=fit,
                              status=judged.status, shift=judged.shift, yaw_deg=judged.yaw_deg,
                              tilt_deg=judged.tilt_deg, upright_bias=prior.upright_bias, reason=reason)
    return observation, model_pts, owner


def _explained_by(object_pts: np.ndarray, mesh: trimesh.Trimesh, fit: RegistrationResult,
                  known: Sequence[KnownSurface], config: MissionConfig, icp: IcpConfig) -> Explanation | None:
    """The known surface that explains at least ``explained_fraction`` of the fit's inliers, or None."""
    if not known or not math.isfinite(fit.rmse):
        return None
    inliers = fit_inliers(object_pts, KnownSurface.of_mesh("fit", mesh, fit.pose), icp.score_distance)
    owner = explaining_surface(inliers, known, config.explained_distance)
    return owner if owner is not None and owner.fraction >= config.explained_fraction else None


def _registered_name(observation: Observation) -> str:
    """How a report names an object registered earlier in the mission: its family and GlobalId (or "new")."""
    which = observation.global_id or "new"
    return f"the {observation.family} ({which}) registered at station {observation.station}"
