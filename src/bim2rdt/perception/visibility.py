"""Whether a registered model faces the camera that saw the points: the check that rejects mirror solutions.

A camera sees the near side of an object. Points on a small arc of a drum are fit equally well by the drum
where it is and by a drum a diameter nearer the camera with the points on its far side, which the camera could
never have seen: its near side would be in the way. ICP cannot tell the two apart by distances; the surface
normals can. For each scene point near the posed model, the nearest model sample's outward normal must point
towards the camera that measured the point.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree


def facing_fraction(T_world_model: np.ndarray, model_pts: np.ndarray, model_normals: np.ndarray,
                    points_world: np.ndarray, cameras_world: np.ndarray, near: float = 0.03,
                    tree: cKDTree | None = None) -> float:
    """Fraction (0-1) of the scene points within ``near`` m of the posed model whose nearest model sample
    faces their camera (``cameras_world``: (3,) for all, or (N, 3) per point); 0 when no point is near."""
    tree = tree if tree is not None else cKDTree(model_pts)
    R, t = T_world_model[:3, :3], T_world_model[:3, 3]
    distance, index = tree.query((points_world - t) @ R, distance_upper_bound=near)
    close = np.isfinite(distance)
    if not close.any():
        return 0.0
    normals_world = model_normals[index[close]] @ R.T
    towards = np.broadcast_to(cameras_world, points_world.shape)[close] - points_world[close]
    return float(np.mean(np.einsum("ni,ni->n", normals_world, towards) > 0.0))
