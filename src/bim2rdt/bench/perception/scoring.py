"""Scoring one detector's observations on one frame against the simulated truth.

An observation is matched to what its detection's mask (or box) mostly shows: an object, a worker, or nothing.
Objects at least :data:`MIN_VISIBLE` visible must be found (recall); an observation of one is a true positive
once (a second one of the same object is a false positive); an observation of an object less visible than that
counts neither way; an observation of nothing is a false positive, as is a worker given a family (a worker
called "unknown" is right, and counted apart). Family accuracy is over true positives; pose errors (translation,
tilt, and yaw modulo the family's symmetry) over true positives with the right family.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bim2rdt.perception import UNKNOWN_FAMILY, Detection, Observation
from bim2rdt.sim.reality import TrueObject
from bim2rdt.sim.scene import WORKER
from bim2rdt.registration.symmetry import closest_equivalent
from bim2rdt.sim.truth import pose_error, true_symmetry

MIN_VISIBLE = 0.3
"""Objects at least this visible (fraction of their unoccluded, uncropped image area) must be detected."""
NOTHING = -1000


@dataclass
class Tally:
    """Counts and per-object errors of one detector over many frames."""

    required: int = 0
    found: int = 0
    true_positives: int = 0
    false_positives: int = 0
    right_family: int = 0
    workers_seen: int = 0
    workers_unknown: int = 0
    translation_m: list[float] = field(default_factory=list)
    tilt_deg: list[float] = field(default_factory=list)
    yaw_deg: list[float] = field(default_factory=list)
    confusions: dict[str, int] = field(default_factory=dict)

    def add(self, other: Tally) -> None:
        for name in ("required", "found", "true_positives", "false_positives", "right_family", "workers_seen",
                     "workers_unknown"):
            setattr(self, name, getattr(self, name) + getattr(other, name))
        self.translation_m += other.translation_m
        self.tilt_deg += other.tilt_deg
        self.yaw_deg += other.yaw_deg
        for key, count in other.confusions.items():
            self.confusions[key] = self.confusions.get(key, 0) + count


def score_frame(observations: list[Observation], detections: list[Detection], labels: np.ndarray,
                truth: list[TrueObject], visible: dict[int, float]) -> Tally:
    """Score one frame (see the module docs)."""
    tally = Tally(required=sum(1 for v in visible.values() if v >= MIN_VISIBLE))
    shown = {_bbox(d): _shows(d, labels) for d in detections}
    matched: set[int] = set()
    for obs in observations:
        target = shown.get(obs.bbox, NOTHING)
        if target == WORKER:
            tally.workers_seen += 1
            tally.workers_unknown += obs.family == UNKNOWN_FAMILY
            tally.false_positives += obs.family != UNKNOWN_FAMILY
        elif target == NOTHING or target in matched:
            tally.false_positives += 1
        elif visible.get(target, 0.0) >= MIN_VISIBLE:
            matched.add(target)
            _true_positive(tally, obs, truth[target])
    tally.found = len(matched)
    return tally


def _true_positive(tally: Tally, obs: Observation, true: TrueObject) -> None:
    tally.true_positives += 1
    if obs.family != true.family:
        key = f"{true.family} -> {obs.family}"
        tally.confusions[key] = tally.confusions.get(key, 0) + 1
        return
    tally.right_family += 1
    error = pose_error(obs.family, obs.pose, true.T_world_model)
    tally.translation_m.append(error.translation)
    tally.tilt_deg.append(error.tilt_deg)
    tally.yaw_deg.append(yaw_error_deg(obs.family, obs.pose, true.T_world_model))


def yaw_error_deg(family: str, T_est: np.ndarray, T_true: np.ndarray) -> float:
    """|yaw| difference (deg) about world z of the estimate's symmetric equivalent closest to the truth."""
    closest = closest_equivalent(T_est, T_true, true_symmetry(family))
    yaw = np.arctan2(closest[1, 0], closest[0, 0]) - np.arctan2(T_true[1, 0], T_true[0, 0])
    return float(abs((np.rad2deg(yaw) + 180.0) % 360.0 - 180.0))


def _shows(detection: Detection, labels: np.ndarray) -> int:
    """What a detection mostly shows: an object index, ``WORKER``, or ``NOTHING`` (background)."""
    if detection.mask is not None and np.shape(detection.mask) == labels.shape:
        seen = labels[np.asarray(detection.mask, dtype=bool)]
    elif detection.bbox is not None:
        u0, v0, u1, v1 = detection.bbox
        seen = labels[max(v0, 0):v1, max(u0, 0):u1].ravel()
    else:
        return NOTHING
    things = seen[(seen >= 0) | (seen == WORKER)]
    if len(things) < 0.3 * max(len(seen), 1):
        return NOTHING
    values, counts = np.unique(things, return_counts=True)
    return int(values[np.argmax(counts)])


def _bbox(detection: Detection) -> tuple | None:
    return tuple(int(c) for c in detection.bbox) if detection.bbox is not None else None
