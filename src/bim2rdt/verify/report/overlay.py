"""Pictures of one frame for the report and the BCF: its colour image with the outlines of the elements it saw
(each element's mesh projected through the fixed pose, its convex hull drawn in the status colour), and its depth
residual against the BIM (each pixel's measured depth minus the depth of the BIM surface on the same ray).

Camera frames are OpenCV's (x right, y down, z forward); ``T_world_camera`` maps camera to world, metres.
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np
import trimesh
from PIL import Image, ImageDraw
from scipy.spatial import ConvexHull, QhullError

from bim2rdt.perception import Intrinsics

NEAR_M = 0.05
"""Vertices closer than this to the camera plane are left out of an outline."""
RESIDUAL_SCALE_M = 0.15
"""The heat map's colour scale: a residual of +-15 cm is full red / full blue."""
NO_DATA_RGB = (200, 200, 200)
SCALE = 2
"""Pictures are drawn at twice the copy's size (sharper outlines and labels)."""


@dataclass(frozen=True)
class Outline:
    """An element to outline: its mesh vertices (N, 3) in the world (metres), an RGB colour and a label."""

    vertices_world: np.ndarray
    rgb: tuple[int, int, int]
    label: str


def project(points_world: np.ndarray, T_world_camera: np.ndarray, intrinsics: Intrinsics) -> np.ndarray:
    """Pixel coordinates (u, v) of the points in front of the camera.

    Args:
        points_world: (N, 3) world points, metres.
        T_world_camera: 4x4 camera-to-world pose.
        intrinsics: The pinhole the pixels are of.

    Returns:
        (M, 2) pixels of the M points at least :data:`NEAR_M` in front of the camera.
    """
    camera = (np.asarray(points_world, float) - T_world_camera[:3, 3]) @ T_world_camera[:3, :3]
    camera = camera[camera[:, 2] > NEAR_M]
    u = intrinsics.fx * camera[:, 0] / camera[:, 2] + intrinsics.cx
    v = intrinsics.fy * camera[:, 1] / camera[:, 2] + intrinsics.cy
    return np.stack([u, v], axis=1)


def outlined_png(rgb: np.ndarray, intrinsics: Intrinsics, T_world_camera: np.ndarray,
                 outlines: list[Outline]) -> bytes:
    """The image with each element's projected outline and label.

    Args:
        rgb: (h, w, 3) uint8 image of the camera ``intrinsics`` describe.
        intrinsics: The image's pinhole.
        T_world_camera: The frame's fixed pose (4x4).
        outlines: The elements to draw.

    Returns:
        A PNG, twice the image's size.
    """
    image = Image.fromarray(np.asarray(rgb, np.uint8)).resize((rgb.shape[1] * SCALE, rgb.shape[0] * SCALE))
    draw = ImageDraw.Draw(image)
    for outline in outlines:
        hull = _hull(project(outline.vertices_world, T_world_camera, intrinsics) * SCALE)
        if hull is None:
            continue
        draw.polygon([tuple(p) for p in hull], outline=outline.rgb, width=3)
        x, y = hull[np.argmin(hull[:, 1])]
        draw.text((float(x), float(max(y - 12, 0))), outline.label, fill=outline.rgb)
    return _png(image)


def residual_m(depth: np.ndarray, intrinsics: Intrinsics, T_world_camera: np.ndarray,
               bim: trimesh.Trimesh) -> np.ndarray:
    """Each pixel's measured range minus the range to the BIM's first surface on its ray (metres; NaN where the
    sensor had no return or the ray meets no BIM surface). Negative: something in front of the BIM.

    Args:
        depth: (h, w) depth along z, metres (NaN or 0: no return).
        intrinsics: The depth image's pinhole.
        T_world_camera: The frame's fixed pose (4x4).
        bim: The model's bodies in the world, one mesh.

    Returns:
        (h, w) residuals, metres.
    """
    rays = intrinsics.pixel_rays().reshape(-1, 3)
    z = np.asarray(depth, float).reshape(-1)
    valid = np.isfinite(z) & (z > 0)
    lengths = np.linalg.norm(rays, axis=1)
    directions = (rays / lengths[:, None]) @ T_world_camera[:3, :3].T
    measured = z * lengths
    expected = np.full(len(z), np.nan)
    index = np.flatnonzero(valid)
    if len(index):
        origins = np.broadcast_to(T_world_camera[:3, 3], (len(index), 3))
        hits, ray_ids, _ = bim.ray.intersects_location(origins, directions[index], multiple_hits=False)
        expected[index[ray_ids]] = np.linalg.norm(hits - T_world_camera[:3, 3], axis=1)
    return (measured - expected).reshape(depth.shape)


def heat_png(residual: np.ndarray, scale_m: float = RESIDUAL_SCALE_M) -> bytes:
    """A diverging colour picture of residuals: blue in front of the BIM, white on it, red behind; grey: no data.

    Args:
        residual: (h, w) metres, NaN for no data.
        scale_m: The residual shown in full colour.

    Returns:
        A PNG, twice the residuals' size.
    """
    t = np.clip(np.nan_to_num(residual, nan=0.0) / scale_m, -1.0, 1.0)
    white = 1.0 - np.abs(t)
    rgb = np.stack([np.where(t > 0, 1.0, white), white, np.where(t < 0, 1.0, white)], axis=-1) * 255
    rgb[~np.isfinite(residual)] = NO_DATA_RGB
    image = Image.fromarray(rgb.astype(np.uint8))
    return _png(image.resize((image.width * SCALE, image.height * SCALE), Image.Resampling.NEAREST))


def _hull(pixels: np.ndarray) -> np.ndarray | None:
    if len(pixels) < 3:
        return None
    try:
        return pixels[ConvexHull(pixels).vertices]
    except QhullError:  # all on a line
        return None


def _png(image: Image.Image) -> bytes:
    buffer = io.BytesIO()
    image.save(buffer, format="PNG")
    return buffer.getvalue()
