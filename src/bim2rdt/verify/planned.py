"""Is each planned object where the BIM puts it? Its own BIM body registered to the scan points around its planned
place, from its planned pose.

A detector names what it finds by family; verifying a BIM needs less and more: the element, its own shape
(office1's four cupboards are one family of four sizes, and a family's template fits none but the first), and
the scan near where the BIM says it stands. So, for the located points the permanent structure does not explain:

1. every planned object (perception's movable elements: furniture, proxies, equipment) whose planned surface the
   sensor could see from its fixed pose (a ray cast that stops on walls and on the other objects);
2. each such point goes to the object whose planned surface is nearest, within ``search`` m (a point claimed by
   one object is not another's);
3. where it stands in plan: the object's body (the BIM's mesh in its own frame) is searched for and registered
   to its points from the planned pose, yaw only, resting on the slab when the BIM puts it there;
4. the BIM pose wins ties: the found pose replaces it only when it explains the view better, by the share of the
   object's sensor-facing surface (not behind a wall) with a located point within ``support`` m ("coverage").
   A thin strip of a built-in cupboard, its front face half the width of the clutter beside it, otherwise turns
   19 degrees onto that clutter while its planned pose covers its face; a desk moved 30 cm in the BIM covers
   little where the BIM puts it and more where it stands. Coverage counts the object's own points only (those
   nearest its planned surface): a cupboard in a row of flush fronts must not slide onto its neighbour's;
5. the kept pose is fitted the way the mission fits (:func:`bim2rdt.perception.fitting.fit_detection`, the one
   fitting path): SG-ICP refines it under the family's upright prior, resting on the slab, so a lean the data
   demands is kept (docs/decisions/0012: the demo's knocked cone, tilted 12 degrees) and a tilt fitted to noise
   is not;
6. the fitted pose is an observation of that element, and its place as the sensor saw it (:func:`place_evidence`)
   the rest of the evidence: the one judge (:func:`bim2rdt.twin.judge_evidence`, the mission's too) and then the
   twin's tolerance preset decide, so verify and the demo's mission agree on every verdict.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from bim2rdt.bim import BimElement, BimModel
from bim2rdt.localization import voxel_means
from bim2rdt.perception import FitRules, Observation, fit_detection, movable_elements
from bim2rdt.registration import IcpConfig, RegistrationError, SampleTree, register
from bim2rdt.semantics import UprightPrior
from bim2rdt.twin import ElementStatus, FitEvidence, JudgeConfig, PlaceEvidence, judge_evidence
from bim2rdt.verify.bodies import body_samples
from bim2rdt.verify.fusion import ElementLook
from bim2rdt.verify.shift_search import Located, best_shift


class PlannedConfig(BaseModel):
    """Knobs of the planned-object check (lengths in metres)."""

    model_config = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)

    search: float = 0.5
    """A located point within this of an object's planned surface may be that object's: farther than the largest
    deviation worth finding by registration (a 30 cm move) and then some."""
    min_points: int = 30
    """Fewer points than this and the object is not judged from this view (in view, but too little of it)."""
    min_visible_rays: int = 20
    """An object whose planned surface fewer rays of the sensor's view reach is out of view."""
    voxel: float = 0.03
    """The points are thinned to one per cube of this size (their mean) before registration."""
    support: float = 0.04
    """A surface sample with a located point this close is covered (the depth noise at 4-5 m, and then some)."""
    coverage_samples: int = 300
    """Coverage is counted on at most this many of the object's sensor-facing samples (evenly thinned)."""
    min_gain_z: float = 2.5
    """The found pose replaces the planned one only when it covers more of the object's surface by this many
    standard errors (a two-proportion z on ``coverage_samples``): office1's own boxes gain z <= 1.3 from the
    search (noise, flush fronts) except the niche cupboard half hidden by a box (2.4); the desk moved 30 cm in the
    BIM gains 3.0. Hence the second condition, free space: ``min_through_drop``."""
    min_through_drop: float = 0.03
    """... and only when the sensor saw through less of the found pose's surface than of the planned one's, by this
    share: a planned place the sensor sees past is contradicted by free space (the moved desk: 27 % -> 20 %); a
    shift that merely lands on more clutter is not (the niche cupboard: 12.5 % -> 12.2 %)."""
    samples: int = 3000
    """Surface samples of the object's body for registration."""
    slab_contact: float = 0.05
    """An object whose planned lowest point is this close to the slab rests on it during registration."""
    icp: IcpConfig = Field(default_factory=lambda: IcpConfig(max_pair_distance=0.1, huber_delta=0.02,
                                                             score_distance=0.05, restarts=1, yaw_jitter_deg=0.0,
                                                             hop_rounds=0))
    upright: bool = False
    """Keep the plan search's pose (upright, yaw only) and skip the mission's fit under the family's prior: a
    knocked cone then reads as planned (what the round-trip test must catch)."""


@dataclass(frozen=True)
class PlannedFit:
    """One planned object checked: its element, the observation (its fitted pose) and how many points."""

    element: BimElement
    observation: Observation


def planned_in_view(model: BimModel, hits: dict[str, int], config: PlannedConfig) -> list[BimElement]:
    """The movable elements with at least ``min_visible_rays`` ray hits (``hits``: GlobalId -> rays)."""
    return [el for el in movable_elements(model) if hits.get(el.global_id, 0) >= config.min_visible_rays]


def check_planned(points_world: np.ndarray, elements: list[BimElement], model: BimModel, slab: float,
                  frame_index: int, sensor_world: np.ndarray, behind_walls, seen_through=None,
                  config: PlannedConfig = PlannedConfig(),
                  priors: Mapping[str, UprightPrior] | None = None) -> list[PlannedFit]:
    """Register each of ``elements`` to the ``points_world`` (N, 3; located, structure removed) nearest its
    planned surface, seen from ``sensor_world`` (3,); ``behind_walls(points (K, 3)) -> (K,) bool`` says which
    surface points a wall hides; ``seen_through(points (K, 3), margin) -> (K,) bool`` which ones the sensor saw
    past by more than ``margin`` (its ray measured farther). The kept poses, fitted under each family's upright
    prior (``priors``: family -> prior; none: the default bias), as observations (``detector`` "bim", ``frames``
    (frame_index,)); an observation's ``fit`` is the plan search's registration, its pose and score (no fit
    report: the observation's own ``rmse`` and ``fitness`` are the agreement at the kept pose)."""
    if not elements or len(points_world) == 0:
        return []
    bodies = {el.global_id: _body(model, el, config) for el in elements}
    owner = _nearest_planned(points_world, elements, bodies, config.search)
    fits = []
    for k, element in enumerate(elements):
        mine = points_world[owner == k]
        points = voxel_means(mine, config.voxel) if len(mine) else mine
        if len(points) < config.min_points:
            continue
        body = bodies[element.global_id]
        located = Located(points)  # its own points only: a cupboard in a row of fronts must not slide onto the next
        covered: dict[bytes, tuple[float, float]] = {}  # a pose's coverage is asked for up to 3 times

        def cover(pose):
            key = np.asarray(pose, dtype=float).tobytes()
            if key not in covered:
                covered[key] = coverage(body, pose, sensor_world, behind_walls, located, config.support,
                                        config.coverage_samples, seen_through)
            return covered[key]

        searched = search_shift(body, element.placement, sensor_world, located, config)
        fit = _register(element, body, points, slab, searched, config)
        candidates = [searched] + ([fit.pose] if fit is not None else [])
        best = max(candidates, key=lambda pose: cover(pose)[0])
        moved = better(cover(element.placement), cover(best), config)
        pose = best if moved else element.placement
        if not config.upright:  # fitted as the mission fits, kept when the view favours it as it favours a move
            fit_pose = fitted(body, points, pose, (priors or {}).get(element.family or ""), slab, config)
            pose = fit_pose if better(cover(pose), cover(fit_pose), config) else pose
        rmse, fitness = _agreement(body, pose, points, config.icp.score_distance)
        fits.append(PlannedFit(element, Observation(
            element.family or element.ifc_class, element.global_id, pose, rmse, fitness, len(points),
            score=cover(pose)[0], detector="bim", frames=(frame_index,), fit=fit)))
    return fits


def fitted(body, points: np.ndarray, kept: np.ndarray, prior: UprightPrior | None, slab: float,
           config: PlannedConfig) -> np.ndarray:
    """The ``kept`` pose (the BIM's, or the one the view found) refined as the mission refines a detection's
    pose after its search (:func:`~bim2rdt.perception.fitting.fit_detection` with ``refine_detector_pose``): SG-ICP
    under the family's upright ``prior``, resting on the slab at ``slab`` when the kept pose does; its tilt
    released when the data overrule the prior (docs/decisions/0012). ``kept`` itself when registration fails."""
    samples, normals = body
    rules = FitRules(config.icp, slab_contact=config.slab_contact, refine_detector_pose=True)
    try:  # the kept pose is also the "detector's": the result of the plan search, refined, not searched again
        return fit_detection(samples, normals, points, kept, [kept], prior, slab, rules, report=False).pose
    except RegistrationError:
        return kept


def look_at(element: BimElement, fit: PlannedFit | None, model: BimModel, sensor_world: np.ndarray, behind_walls,
            compare, frame_index: int, config: PlannedConfig, judge: JudgeConfig, min_fitness: float) -> ElementLook:
    """One planned element as one frame saw it: its place at the
    planned pose, its ``fit`` (distrusted when the sensor measured on under ``judge.min_fit_on`` of the fitted
    body's surface in the image: the fit landed on something else), and the one judge's verdict on this frame."""
    body = _body(model, element, config)
    place = place_evidence(body, element.placement, sensor_world, behind_walls, compare, config.support)
    evidence, observation = None, None
    if fit is not None:
        observation = fit.observation
        at_fit = place_evidence(body, observation.pose, sensor_world, behind_walls, compare, config.support)
        problem = ""
        if at_fit.in_sight + at_fit.hidden and at_fit.on_share < judge.min_fit_on:
            problem = (f"(the sensor measured on only {at_fit.on_share:.0%} of the fitted body's surface in the "
                       f"image, under {judge.min_fit_on:.0%}: the fit landed on something else)")
        evidence = FitEvidence(observation.fitness, problem)
    judgement = judge_evidence(place, evidence, min_fitness, judge)
    if observation is not None:
        if judgement.status is ElementStatus.MISSING:
            observation = None
        elif judgement.status is not None:
            observation = replace(observation, status=judgement.status, reason=judgement.reason)
    return ElementLook(element.global_id, frame_index, place, evidence, observation, judgement)


def place_evidence(body, T_world_model: np.ndarray, sensor_world: np.ndarray, behind_walls, compare,
                   margin: float) -> PlaceEvidence:
    """How the sensor at ``sensor_world`` saw the body (``body``: samples and normals in its own frame) posed by
    ``T_world_model``: its sensor-facing samples in front of the walls, those with a return on or past them (in
    sight), past them by more than ``margin`` m (seen through), nearer (hidden). ``compare(points, margin)``:
    1 past, 0 on, -1 nearer, NaN no return (:meth:`~bim2rdt.verify.rays.RangeLookup.compare`)."""
    samples, normals = body
    points = samples @ T_world_model[:3, :3].T + T_world_model[:3, 3]
    facing = np.einsum("ni,ni->n", normals @ T_world_model[:3, :3].T, sensor_world - points) > 0
    facing[facing] = ~behind_walls(points[facing])
    seen = compare(points[facing], margin)
    return PlaceEvidence(int(facing.sum()), int(np.sum(seen >= 0)), int(np.sum(seen > 0)), int(np.sum(seen < 0)))


def _body(model: BimModel, element: BimElement, config: PlannedConfig):
    return body_samples(model, element.global_id, config.samples, config.icp.seed)




def search_shift(body, placement: np.ndarray, sensor_world: np.ndarray, located: Located,
                 config: PlannedConfig) -> np.ndarray:
    """The planned pose shifted in plan (and turned a little about its own up) to where its sensor-facing surface
    finds the most located points: a 5 cm grid over +-``search``, then a 1 cm grid with turns of up to 6 deg.
    Registration from the planned pose alone slides onto the clutter around a small object (a chair before a
    desk, monitors on it); coverage counts only what the object's own faces land on."""
    samples, normals = body
    facing = np.einsum("ni,ni->n", normals @ placement[:3, :3].T,
                       sensor_world - (samples @ placement[:3, :3].T + placement[:3, 3])) > 0
    local = samples[facing][:: max(1, int(facing.sum()) // config.coverage_samples)]
    if len(local) == 0:
        return placement
    coarse = np.arange(-config.search, config.search + 1e-9, 0.05)
    best, _ = best_shift(local, placement, [0.0], coarse, located, config.support)
    fine = np.arange(-0.04, 0.04 + 1e-9, 0.01)
    pose, _ = best_shift(local, best, [-6.0, -3.0, 0.0, 3.0, 6.0], fine, located, config.support)
    return pose


def _agreement(body, pose: np.ndarray, points: np.ndarray, distance: float) -> tuple[float, float]:
    """(RMS distance of the points within ``distance`` of the posed body's samples, their share among the points
    within 3 x ``distance``): the kept pose's rmse and fitness. Only the object's neighbourhood counts: the
    points nearest its planned surface reach half a metre out, over the clutter around it."""
    samples, _ = body
    gap, _ = SampleTree(samples @ pose[:3, :3].T + pose[:3, 3]).query(points, distance_upper_bound=3 * distance)
    gap = gap[np.isfinite(gap)]
    near = gap <= distance
    if len(gap) == 0:
        return float("inf"), 0.0
    return (float(np.sqrt(np.mean(gap[near] ** 2))) if near.any() else float("inf")), float(near.mean())


def better(kept: tuple[float, float], found: tuple[float, float], config: PlannedConfig) -> bool:
    """Whether a ``found`` pose explains the view better than the ``kept`` one (each (coverage, seen-through
    share), :func:`coverage`): more coverage by ``min_gain_z`` standard errors, and less seen through by
    ``min_through_drop``. The BIM pose, and any pose kept, wins the rest."""
    return gain_z(kept[0], found[0], config.coverage_samples) >= config.min_gain_z and \
        kept[1] - found[1] >= config.min_through_drop


def gain_z(planned: float, found: float, samples: int) -> float:
    """How many standard errors ``found`` coverage exceeds ``planned`` (two proportions of ``samples`` each)."""
    pooled = (planned + found) / 2
    spread = np.sqrt(max(pooled * (1 - pooled), 1e-9) * 2 / samples)
    return float((found - planned) / spread)


def coverage(body, T_world_model: np.ndarray, sensor_world: np.ndarray, behind_walls, located: Located,
             support: float, samples_used: int, seen_through=None) -> float:
    """Share of the body's surface samples (posed by ``T_world_model``) that face the sensor, lie in front of the
    walls, and have a located point within ``support`` m: how much of what the sensor should see of the object
    there it did see (0 when it should see nothing)."""
    samples, normals = body
    points = samples @ T_world_model[:3, :3].T + T_world_model[:3, 3]
    facing = np.einsum("ni,ni->n", normals @ T_world_model[:3, :3].T, sensor_world - points) > 0
    facing[facing] = ~behind_walls(points[facing])
    if not facing.any():
        return 0.0
    seen = points[facing][:: max(1, int(facing.sum()) // samples_used)]
    gap, _ = located.query(seen, distance_upper_bound=support)
    through = seen_through(seen, support).mean() if seen_through is not None else 0.0
    return float(np.isfinite(gap).mean()), float(through)


def owned_points(points_world: np.ndarray, elements: list[BimElement], model: BimModel,
                 config: PlannedConfig = PlannedConfig()) -> np.ndarray:
    """(N,) index into ``elements`` of the planned surface nearest each of ``points_world`` within ``search`` m,
    -1 for none: the points :func:`check_planned` gives each object."""
    bodies = {el.global_id: _body(model, el, config) for el in elements}
    return _nearest_planned(points_world, elements, bodies, config.search)


def _nearest_planned(points_world: np.ndarray, elements: list[BimElement], bodies, search: float) -> np.ndarray:
    """(N,) index into ``elements`` of the planned surface nearest each point within ``search``, -1 for none."""
    samples, owner = [], []
    for k, element in enumerate(elements):
        body, _ = bodies[element.global_id]
        T = element.placement
        samples.append(body @ T[:3, :3].T + T[:3, 3])
        owner.append(np.full(len(body), k))
    # pykdtree through SampleTree: cKDTree's answers, ~4x faster on a frame's ~60,000 points with this wide bound
    distance, index = SampleTree(np.concatenate(samples)).query(points_world, distance_upper_bound=search)
    owners = np.concatenate(owner)
    return np.where(np.isfinite(distance), owners[np.minimum(index, len(owners) - 1)], -1)


def _register(element: BimElement, body, points: np.ndarray, slab: float, start: np.ndarray, config: PlannedConfig):
    samples, normals = body
    lowest = float((samples @ element.placement[:3, :3].T + element.placement[:3, 3])[:, 2].min())
    support = slab if abs(lowest - slab) <= config.slab_contact else None
    try:
        return register(samples, normals, points, init=start, up=(0.0, 0.0, 1.0), upright_bias=0.0,
                        yaw_only=True, config=config.icp, support_height=support, report=False)  # pose read
    except RegistrationError:
        return None
