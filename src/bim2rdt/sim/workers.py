"""Workers walking through the camera's view: people are on every site, in no BIM, and often in front of the
objects a robot came to check. A perception front end must call them "unknown", never a drum."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from bim2rdt.sim.meshes import worker
from bim2rdt.sim.scene import PlacedObject, ground_pose

HI_VIS = (0.92, 0.80, 0.12)
"""A hi-vis vest's yellow (RGB 0-1)."""
CLEARANCE = 0.9
"""How close (m, in plan) a worker may stand to an object's origin or a building element's footprint."""


def worker_in_view(T_world_camera: np.ndarray, rng: np.random.Generator, keep_clear_xy: Sequence[np.ndarray] = (),
                   footprints: Sequence[np.ndarray] = (), near: float = 1.2, far: float = 4.5,
                   half_fov_deg: float = 25.0, attempts: int = 30) -> PlacedObject | None:
    """A worker standing in the camera's view, ``near``-``far`` m ahead and within ``half_fov_deg`` of the
    optical axis (in plan), at least :data:`CLEARANCE` from every ``keep_clear_xy`` point and outside every
    footprint (xmin, ymin, xmax, ymax) grown by half that; None when no such spot turns up."""
    forward = T_world_camera[:2, 2] / max(np.linalg.norm(T_world_camera[:2, 2]), 1e-9)
    heading0 = np.arctan2(forward[1], forward[0])
    for _ in range(attempts):
        bearing = heading0 + np.deg2rad(rng.uniform(-half_fov_deg, half_fov_deg))
        xy = T_world_camera[:2, 3] + rng.uniform(near, far) * np.array([np.cos(bearing), np.sin(bearing)])
        if _clear(xy, keep_clear_xy, footprints):
            return PlacedObject("worker", worker(), ground_pose(*xy, yaw_rad=rng.uniform(0, 2 * np.pi)),
                                colour=HI_VIS)
    return None


def _clear(xy: np.ndarray, points: Sequence[np.ndarray], footprints: Sequence[np.ndarray]) -> bool:
    if any(np.linalg.norm(xy - np.asarray(p)[:2]) < CLEARANCE for p in points):
        return False
    margin = CLEARANCE / 2
    return not any(box[0] - margin <= xy[0] <= box[2] + margin and box[1] - margin <= xy[1] <= box[3] + margin
                   for box in footprints)
