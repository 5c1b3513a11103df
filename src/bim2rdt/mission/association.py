"""Which BIM element a detection shows: the nearest unclaimed element of its family within reach, or none (new).

Nearest-first alone can hand a moved object its neighbour's element: two drums of one family, one moved 30 cm
towards the other's place, take the other's element first, and the second drum is left with none within reach
(a phantom "new" drum, and later the first drum's element 1.5 m "off"). So the detections of one frame are first
assigned jointly (:func:`preferred_targets`: the least total distance, within ``association_radius``), and a
detection takes its preferred element when that is still unclaimed."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Mapping, Sequence

import numpy as np
from scipy.optimize import linear_sum_assignment

from bim2rdt.mission.config import MissionConfig
from bim2rdt.mission.ground import object_centroid
from bim2rdt.mission.records import Target
from bim2rdt.perception.detection import Detection

OUT_OF_REACH = 1e6
"""The assignment's cost of a pair farther apart than ``association_radius`` (dropped afterwards)."""


def associate(detection: Detection, targets: Sequence[Target], claimed: set[str], config: MissionConfig,
              preferred: Mapping[int, Target] | None = None) -> Target | None:
    """The element ``detection`` shows (claimed by it), or None for an object the BIM lacks: its
    ``preferred[id(detection)]`` element when unclaimed, else the nearest unclaimed one of its family in reach."""
    choice = (preferred or {}).get(id(detection))
    if choice is not None and choice.global_id not in claimed:
        claimed.add(choice.global_id)
        return choice
    centre = object_centroid(detection.points_world, config)
    candidates = [t for t in targets if t.family == detection.family and t.global_id not in claimed]
    if not candidates:
        return None
    nearest = min(candidates, key=lambda t: np.linalg.norm(t.placement[:2, 3] - centre[:2]))
    if np.linalg.norm(nearest.placement[:2, 3] - centre[:2]) > config.association_radius:
        return None
    claimed.add(nearest.global_id)
    return nearest


def preferred_targets(detections: Sequence[Detection], targets: Sequence[Target],
                      config: MissionConfig) -> dict[int, Target]:
    """{id(detection): element}: per station and family, the assignment of that frame's detections to the BIM's
    elements with the most pairs within ``association_radius`` and, among those, the least total distance."""
    frames: dict[tuple, list[Detection]] = defaultdict(list)
    for detection in detections:
        frames[(detection.station, detection.family)].append(detection)
    preferred = {}
    for (_, family), group in frames.items():
        candidates = [t for t in targets if t.family == family]
        if not candidates:
            continue
        centres = np.array([object_centroid(d.points_world, config)[:2] for d in group])
        places = np.array([t.placement[:2, 3] for t in candidates])
        distance = np.linalg.norm(centres[:, None, :] - places[None, :, :], axis=2)
        reach = distance <= config.association_radius
        rows, cols = linear_sum_assignment(np.where(reach, distance, OUT_OF_REACH))
        preferred.update({id(group[r]): candidates[c] for r, c in zip(rows, cols) if reach[r, c]})
    return preferred
