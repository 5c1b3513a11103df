"""Free-space consistency: a registered model must not stand where the camera saw through.

A depth camera measures where the first surface is along every ray, so it also measures that nothing is in
front of it. A pose that puts a model surface, facing the camera, in front of a measured point along the same
ray claims a surface the camera looked through: a drum fit to an arc of points with the points on its far side
(the mirror solution, equally good by ICP's distances), a tripod fit to a worker's forearm (its other legs
stand where the camera sees the wall), a crate fit to part of a beam (its body where the camera sees slab).

The test projects the posed model's camera-facing surface samples into the frame, keeps the nearest per pixel
(the model's own occlusion), and counts those the measured depth shows the camera saw beyond.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.ndimage import minimum_filter

from bim2rdt.perception.camera import Intrinsics

STRIDE = 2
"""The test works on every second pixel each way: a model's samples are far sparser than a VGA frame's pixels."""


@dataclass(frozen=True)
class DepthView:
    """One frame's depth (H, W) metres (NaN = no return), its intrinsics and ``T_world_camera``."""

    depth: np.ndarray
    intrinsics: Intrinsics
    T_world_camera: np.ndarray

    @cached_property
    def nearest_around(self) -> np.ndarray:
        """Every :data:`STRIDE`-th pixel's nearest measured depth within one grid step (inf: no return around).
        Comparing with the nearest around, not the pixel itself, spares the silhouettes of thin parts (a
        tripod leg two cells wide): a model sample that projects a pixel beside its leg still has the leg next
        to it.

        Returns:
            (ceil(H / STRIDE), ceil(W / STRIDE)) the nearest depth around each grid cell, metres; inf where no
                pixel around has a return.
        """
        grid = np.where(np.isfinite(self.depth) & (self.depth > 0), self.depth, np.inf)[::STRIDE, ::STRIDE]
        return minimum_filter(grid, size=3, mode="nearest")


def see_through_fraction(T_world_model: np.ndarray, model_pts: np.ndarray, model_normals: np.ndarray,
                         view: DepthView, tolerance: float = 0.04) -> float:
    """How much of the posed model's place the camera saw through: of its visible samples (facing the camera,
    nearest in their grid cell, with a depth return around), the fraction behind which the camera measured a
    farther surface by more than ``tolerance``.

    Args:
        T_world_model: (4, 4) the model's pose in the world, metres.
        model_pts: (N, 3) surface samples in the model's body frame, metres.
        model_normals: (N, 3) their outward unit normals, body frame.
        view: The frame's depth, intrinsics and camera pose.
        tolerance: How much farther the measured surface must be to count as seen through, metres.

    Returns:
        The fraction, 0 to 1; 0 when none of the model is in view.
    """
    look = look_at_place(T_world_model, model_pts, model_normals, view, tolerance)
    return look.through / look.seen if look.seen else 0.0


@dataclass(frozen=True)
class PlaceLook:
    """How one frame saw the place of a posed model: ``facing`` samples face the camera in front of it,
    ``in_frame`` of them project into the image; of the cells they cover (the nearest sample per
    :data:`STRIDE` cell), ``seen`` have a depth return around them, ``through`` are where the camera measured a
    surface farther than the model's by more than the tolerance (it looked through the place), ``blocked``
    where it measured one nearer by more than the tolerance (something stands in front: a wall, a worker)."""

    facing: int
    in_frame: int
    seen: int
    through: int
    blocked: int


def look_at_place(T_world_model: np.ndarray, model_pts: np.ndarray, model_normals: np.ndarray, view: DepthView,
                  tolerance: float) -> PlaceLook:
    """Compare the posed model's camera-facing surface samples with the frame's measured depth: project them
    into the frame, keep the nearest per :data:`STRIDE` grid cell, and count where the camera measured beyond
    (through) or in front of (blocked) them.

    Args:
        T_world_model: (4, 4) the model's pose in the world, metres.
        model_pts: (N, 3) surface samples in the model's body frame, metres.
        model_normals: (N, 3) their outward unit normals, body frame.
        view: The frame's depth, intrinsics and camera pose.
        tolerance: How far the measured surface must be behind or in front of the model's to count as
            through or blocked, metres.

    Returns:
        The counts of samples facing the camera, in the image, and of grid cells seen, through and blocked.
    """
    T_camera_world = np.linalg.inv(view.T_world_camera)
    R = T_camera_world[:3, :3] @ T_world_model[:3, :3]
    t = T_camera_world[:3, :3] @ T_world_model[:3, 3] + T_camera_world[:3, 3]
    points = model_pts @ R.T + t
    facing = np.einsum("ni,ni->n", model_normals @ R.T, -points) > 0.0
    points = points[facing & (points[:, 2] > 0.1)]
    k, stride = view.intrinsics, STRIDE
    u = np.floor((points[:, 0] / points[:, 2] * k.fx + k.cx + 0.5) / stride).astype(int)
    v = np.floor((points[:, 1] / points[:, 2] * k.fy + k.cy + 0.5) / stride).astype(int)
    width, height = -(-k.width // stride), -(-k.height // stride)
    inside = (u >= 0) & (u < width) & (v >= 0) & (v < height)
    if not inside.any():
        return PlaceLook(len(points), 0, 0, 0, 0)
    u, v, z = u[inside], v[inside], points[inside, 2]
    nearest = np.full(width * height, np.inf)
    np.minimum.at(nearest, v * width + u, z)
    cells = np.flatnonzero(np.isfinite(nearest))
    measured = view.nearest_around.ravel()[cells]
    seen = np.isfinite(measured)
    expected = nearest[cells][seen]
    return PlaceLook(len(points), int(inside.sum()), int(seen.sum()),
                     int(np.sum(measured[seen] > expected + tolerance)),
                     int(np.sum(measured[seen] < expected - tolerance)))
