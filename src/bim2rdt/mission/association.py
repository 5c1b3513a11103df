"""Which BIM element a detection shows: the nearest unclaimed element of its family within reach, or none (new).

Nearest-first alone can hand a moved object its neighbour's element: two drums of one family, one moved 30 cm
towards the other's place, take the other's element first, and the second drum is left with none within reach
(a phantom "new" drum, and later the first drum's element 1.5 m "off"). So the detections of one frame are first
assigned jointly (:func:`preferred_targets`: the least total distance, within ``association_radius``), and a
detection takes its preferred element when that is still unclaimed."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Collection, Sequence

import numpy as np
from scipy.optimize import linear_sum_assignment

from bim2rdt.mission.config import MissionConfig
from bim2rdt.mission.ground import object_centroid
from bim2rdt.mission.records import Target
from bim2rdt.perception import Detection

OUT_OF_REACH = 1e6
"""The assignment's cost of a pair farther apart than ``association_radius`` (dropped afterwards)."""


def associate(detection: Detection, targets: Sequence[Target], claimed: Collection[str], config: MissionConfig,
              preferred: Target | None = None) -> Target | None:
    """The element ``detection`` shows, or None for an object the BIM lacks: its ``preferred`` element (its
    frame's joint assignment, :func:`preferred_targets`) when that is not in ``claimed`` (GlobalIds), else the
    nearest unclaimed one of its family in reach. The caller claims what it returns."""
    if preferred is not None and preferred.global_id not in claimed:
        return preferred
    centre = object_centroid(detection.points_world, config)
    candidates = [t for t in targets if t.family == detection.family and t.global_id not in claimed]
    if not candidates:
        return None
    nearest = min(candidates, key=lambda t: np.linalg.norm(t.placement[:2, 3] - centre[:2]))
    if np.linalg.norm(nearest.placement[:2, 3] - centre[:2]) > config.association_radius:
        return None
    return nearest


def preferred_targets(detections: Sequence[Detection], targets: Sequence[Target],
                      config: MissionConfig) -> list[Target | None]:
    """Each detection's element (None: none in reach), in the order of ``detections``: per station and family,
    the assignment of that frame's detections to the BIM's elements with the most pairs within
    ``association_radius`` and, among those, the least total distance."""
    frames: dict[tuple, list[int]] = defaultdict(list)
    for index, detection in enumerate(detections):
        frames[(detection.station, detection.family)].append(index)
    preferred: list[Target | None] = [None] * len(detections)
    for (_, family), group in frames.items():
        candidates = [t for t in targets if t.family == family]
        if not candidates:
            continue
        centres = np.array([object_centroid(detections[i].points_world, config)[:2] for i in group])
        places = np.array([t.placement[:2, 3] for t in candidates])
        distance = np.linalg.norm(centres[:, None, :] - places[None, :, :], axis=2)
        reach = distance <= config.association_radius
        rows, cols = linear_sum_assignment(np.where(reach, distance, OUT_OF_REACH))
        for r, c in zip(rows, cols):
            if reach[r, c]:
                preferred[group[r]] = candidates[c]
    return preferred
