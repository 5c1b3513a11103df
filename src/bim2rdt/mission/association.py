"""Which BIM element a detection shows: the nearest unclaimed element of its family within reach, or none (new)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from bim2rdt.mission.config import MissionConfig
from bim2rdt.mission.ground import object_centroid
from bim2rdt.mission.records import Target
from bim2rdt.perception.detection import Detection


def associate(detection: Detection, targets: Sequence[Target], claimed: set[str],
              config: MissionConfig) -> Target | None:
    centre = object_centroid(detection.points_world, config)
    candidates = [t for t in targets if t.family == detection.family and t.global_id not in claimed]
    if not candidates:
        return None
    nearest = min(candidates, key=lambda t: np.linalg.norm(t.placement[:2, 3] - centre[:2]))
    if np.linalg.norm(nearest.placement[:2, 3] - centre[:2]) > config.association_radius:
        return None
    claimed.add(nearest.global_id)
    return nearest
