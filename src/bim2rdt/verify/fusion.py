"""Evidence from every frame: each element judged once, on all the frames that saw it (docs/decisions/0030).

Each frame leaves, per planned element in view, an :class:`ElementLook`: how it saw the element's place, the fit
of its body if any, and the one judge's verdict on that frame alone (:func:`bim2rdt.twin.judge_evidence`). The
fused verdict:

- the frames with a trusted fit: their poses combined, each weighted by its information, the inverse of the fit's
  position covariance in the world. That covariance is the frame's fix covariance carried to the object (a turn
  of the sensor moves the object by the lever arm) plus the fit's own noise, so a frame whose fix leaves a
  direction free (sigma of metres: the demo's bag, four frames of six) weighs nothing along it. A frame farther
  than ``outlier_sigma`` (Mahalanobis) from the others' combination is left out, once. When the combination
  still leaves a horizontal direction looser than ``max_sigma``, the element is unverified, with that direction;
- no trusted fit: the places of all the frames with a usable fix summed (in sight, seen through, hidden) and
  judged with the best untrusted fit, if any: missing, unverified or not observed, with the reason.

New-object clusters of different frames within ``new_match`` of each other are one new object; a cluster that is
a person or moved between frames (:mod:`.transient`) is transient, not new.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from bim2rdt.perception import Observation
from bim2rdt.twin import ElementStatus
from bim2rdt.twin import FitEvidence, JudgeConfig, Judgement, PlaceEvidence, judge_evidence
from bim2rdt.verify.new_objects import NewCluster


class FusionConfig(BaseModel):
    """How the frames' evidence is combined (lengths in metres): ``Settings.verify.fusion`` (``BIM2RDT_VERIFY__FUSION__*``)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    max_sigma: float = Field(0.1, gt=0.0, description="A fix or a fused position looser than this (1 sigma) along "
                             "a horizontal direction leaves that direction free, m.")
    fit_sigma: float = Field(0.01, gt=0.0, description="A trusted fit's own position noise (1 sigma per axis), m.")
    outlier_sigma: float = Field(3.0, gt=0.0, description="A frame's position this many sigma (Mahalanobis, 3 "
                                 "degrees of freedom) from the others' combination is left out.")
    odometry_floor: float = Field(0.02, ge=0.0, description="A recording's own motion since the last fix is good "
                                  "to this (1 sigma, per axis) plus ``odometry_drift`` of the distance, m.")
    odometry_drift: float = Field(0.05, ge=0.0, description="Odometry drift as a share of the distance moved since "
                                  "the last fix (wheel and visual odometry: 1-5 %).")
    odometry_turn_deg: float = Field(1.0, ge=0.0, description="... and its heading to this (1 sigma), degrees.")
    new_match: float = Field(0.5, gt=0.0, description="New-object clusters of different frames whose centres are "
                             "this close in plan are one object, m.")


@dataclass(frozen=True)
class ElementLook:
    """One planned element as one frame saw it: the place, the fit (and its observation) if any, and the judge's
    verdict on this frame alone."""

    global_id: str
    frame: int
    place: PlaceEvidence
    fit: FitEvidence | None
    observation: Observation | None
    judgement: Judgement


@dataclass(frozen=True)
class FusedElement:
    """An element's verdict from all its frames: ``status`` None means the twin judges ``observation``'s pose
    against its tolerance; ``frames`` every frame that saw it; ``sigma`` the fused position's largest horizontal
    1-sigma (m, None without a fit)."""

    global_id: str
    status: ElementStatus | None
    reason: str
    observation: Observation | None
    frames: tuple[int, ...]
    sigma: float | None = None


def horizontal_sigma(covariance: np.ndarray | None) -> float:
    """The largest 1-sigma of a (3, 3) or (6, 6) position covariance in the horizontal plane, m (inf: None)."""
    if covariance is None:
        return float("inf")
    return float(np.sqrt(max(np.linalg.eigvalsh(np.asarray(covariance)[:2, :2]).max(), 0.0)))


def located_covariance(covariance: np.ndarray | None, anchor, anchor_covariance: np.ndarray | None,
                       own: np.ndarray | None, config: FusionConfig = FusionConfig()) -> np.ndarray | None:
    """A fix's (6, 6) ``covariance`` with the information of its prior added, when that prior is the last fix
    (``anchor`` = (its own pose, its fixed pose), ``anchor_covariance`` its located covariance) carried forward by
    the recording's own poses (``own``, this frame's): the anchor's covariance grown by the odometry's drift over
    the distance moved. A fix whose view leaves a direction free (a wall seen straight on) is then as good along
    it as the odometry since the last full fix; without odometry (no own poses, or the user's prior) nothing is
    added."""
    if covariance is None or anchor is None or anchor_covariance is None or own is None or anchor[0] is None:
        return covariance
    moved = float(np.linalg.norm(own[:3, 3] - anchor[0][:3, 3]))
    shift = config.odometry_floor + config.odometry_drift * moved
    drift = np.diag([shift**2] * 3 + [np.deg2rad(config.odometry_turn_deg) ** 2] * 3)
    information = np.linalg.inv(np.asarray(covariance)) + np.linalg.inv(np.asarray(anchor_covariance) + drift)
    return np.linalg.inv(information)


def object_covariance(frame_covariance: np.ndarray | None, camera: np.ndarray, at: np.ndarray,
                      fit_sigma: float) -> np.ndarray:
    """(3, 3) covariance of an object's world position at ``at`` (3,) fitted in a frame whose fix
    (``camera``: T_world_sensor) has ``frame_covariance`` (6, 6: dx, dy, dz, dtheta_x, dtheta_y, dtheta_z; m,
    rad; world axes, turns about the sensor): dp = dt + dtheta x (p - t), plus the fit's own ``fit_sigma``."""
    noise = np.eye(3) * fit_sigma**2
    if frame_covariance is None:
        return noise + np.eye(3) * 1e4
    r = np.asarray(at, dtype=float) - camera[:3, 3]
    J = np.concatenate([np.eye(3), -np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])], axis=1)
    return J @ np.asarray(frame_covariance) @ J.T + noise


def fuse_element(looks: list[ElementLook], fixes: dict[int, tuple[np.ndarray, np.ndarray | None]],
                 min_fitness: float, config: FusionConfig = FusionConfig(),
                 judge: JudgeConfig = JudgeConfig()) -> FusedElement:
    """One element's verdict from its ``looks`` (every frame that had it in view); ``fixes``: frame index ->
    (T_world_sensor, its 6x6 covariance or None)."""
    frames = tuple(sorted({look.frame for look in looks}))
    global_id = looks[0].global_id
    trusted = [look for look in looks if look.judgement.status is None and look.observation is not None]
    if trusted:
        return _fused_pose(global_id, trusted, frames, fixes, config)
    located = [look for look in looks if horizontal_sigma(fixes[look.frame][1]) <= config.max_sigma]
    if not located:
        return FusedElement(global_id, ElementStatus.NOT_OBSERVED, "(seen only from frames whose fix leaves a "
                            "horizontal direction free)", None, frames)
    place = located[0].place
    for look in located[1:]:
        place = place.combined(look.place)
    fitted = [look for look in located if look.fit is not None]
    best = max(fitted, key=lambda look: look.fit.fitness, default=None)
    verdict = judge_evidence(place, best.fit if best else None, min_fitness, judge)
    observation = best.observation if best is not None and verdict.status is ElementStatus.UNVERIFIED else None
    if observation is not None:
        observation = replace(observation, status=ElementStatus.UNVERIFIED, reason=verdict.reason, frames=frames)
    return FusedElement(global_id, verdict.status, verdict.reason, observation, frames)


def _fused_pose(global_id: str, trusted: list[ElementLook], frames: tuple[int, ...],
                fixes: dict[int, tuple[np.ndarray, np.ndarray | None]], config: FusionConfig) -> FusedElement:
    """The trusted fits' positions combined by information (those that agree with the medoid), the yaw of the most
    certain one;
    unverified when a horizontal direction stays looser than ``max_sigma``."""
    positions = np.array([look.observation.pose[:3, 3] for look in trusted])
    covariances = [object_covariance(fixes[look.frame][1], fixes[look.frame][0], p, config.fit_sigma)
                   for look, p in zip(trusted, positions)]
    keep = np.ones(len(trusted), dtype=bool)
    if len(trusted) > 2:  # the medoid (least summed Mahalanobis distance to the others) decides who agrees
        apart = np.array([[_mahalanobis(p, q, a + b) for q, b in zip(positions, covariances)]
                          for p, a in zip(positions, covariances)])
        medoid = int(np.argmin(apart.sum(axis=1)))
        keep = apart[medoid] <= 3 * config.outlier_sigma**2
    mean, covariance = _combine(positions, covariances, keep)
    used = [look for look, k in zip(trusted, keep) if k]
    best = min(used, key=lambda look: np.trace(covariances[trusted.index(look)]))
    pose = best.observation.pose.copy()
    pose[:3, 3] = mean
    sigma = horizontal_sigma(covariance)
    observation = replace(best.observation, pose=pose, frames=tuple(sorted(look.frame for look in used)),
                          points=int(sum(look.observation.points for look in used)))
    if sigma > config.max_sigma:
        direction = np.linalg.eigh(covariance[:2, :2])[1][:, -1]
        reason = (f"(the fixes of the frames that saw it leave it free along {_axis(direction)}: sigma "
                  f"{sigma:.2g} m)")
        return FusedElement(global_id, ElementStatus.UNVERIFIED, reason,
                            replace(observation, status=ElementStatus.UNVERIFIED, reason=reason), frames, sigma)
    return FusedElement(global_id, None, "", observation, frames, sigma)


def _mahalanobis(p: np.ndarray, q: np.ndarray, covariance: np.ndarray) -> float:
    return float((p - q) @ np.linalg.solve(covariance, p - q))


def _combine(positions: np.ndarray, covariances: list[np.ndarray], keep: np.ndarray):
    information = sum(np.linalg.inv(c) for c, k in zip(covariances, keep) if k)
    covariance = np.linalg.inv(information)
    weighted = sum(np.linalg.inv(c) @ p for c, p, k in zip(covariances, positions, keep) if k)
    return covariance @ weighted, covariance


def _axis(direction: np.ndarray) -> str:
    """'x' or 'y' for a plan direction within 25 degrees of a world axis, else its components."""
    k = int(np.argmax(np.abs(direction)))
    return "xy"[k] if abs(direction[k]) >= np.cos(np.deg2rad(25.0)) else f"({direction[0]:.2f}, {direction[1]:.2f})"


def merge_new(clusters: list[NewCluster], config: FusionConfig = FusionConfig()) -> list[NewCluster]:
    """The clusters of all frames as objects: frame by frame, each cluster joins the object whose centre lies
    nearest in plan within ``new_match`` and that no other cluster of its frame joined (two clusters of one
    frame are two objects), else starts one. An object keeps the pose of its cluster with the most points, every
    frame, and is transient if any of its clusters is."""
    objects: list[list[NewCluster]] = []
    for frame in sorted({c.frames[0] for c in clusters}):
        taken: set[int] = set()
        for cluster in sorted((c for c in clusters if c.frames[0] == frame), key=lambda c: -c.observation.points):
            at = cluster.observation.pose[:2, 3]
            distances = [np.linalg.norm(_centre(members) - at) if k not in taken else np.inf
                         for k, members in enumerate(objects)]
            k = int(np.argmin(distances)) if distances else -1
            if k >= 0 and distances[k] <= config.new_match:
                objects[k].append(cluster)
            else:
                k = len(objects)
                objects.append([cluster])
            taken.add(k)
    return sorted((_merged(members) for members in objects), key=lambda c: -c.observation.points)


def _centre(members: list[NewCluster]) -> np.ndarray:
    """An object's plan centre: its largest cluster's."""
    return max(members, key=lambda c: c.observation.points).observation.pose[:2, 3]


def _merged(members: list[NewCluster]) -> NewCluster:
    largest = max(members, key=lambda c: c.observation.points)
    frames = tuple(sorted({f for c in members for f in c.frames}))
    why = next((c.transient for c in members if c.transient), "")
    return replace(largest, observation=replace(largest.observation, frames=frames), frames=frames, transient=why,
                   sample=np.concatenate([c.sample for c in members]),
                   low=np.min([c.low for c in members], axis=0), high=np.max([c.high for c in members], axis=0))


def fuse_frames(results, min_fitness: float, config: FusionConfig = FusionConfig(),
                judge: JudgeConfig = JudgeConfig()) -> tuple[list[FusedElement], list[NewCluster], list[NewCluster]]:
    """Every planned object judged on all the frames that saw it, and the new objects of all located frames
    merged, transient ones apart. ``results``: the frames' results (``index``, ``accepted``, ``pose``,
    ``located_covariance``, ``looks``, ``clusters``)."""
    fixes = {r.index: (r.pose, r.located_covariance) for r in results if r.accepted}
    looks: dict[str, list[ElementLook]] = {}
    for result in results:
        for look in result.looks:
            looks.setdefault(look.global_id, []).append(look)
    elements = [fuse_element(seen, fixes, min_fitness, config, judge) for seen in looks.values()]
    located = [c for r in results if r.accepted and horizontal_sigma(r.located_covariance) <= config.max_sigma
               for c in r.clusters]
    merged = merge_new(located, config)
    return elements, [c for c in merged if not c.transient], [c for c in merged if c.transient]
