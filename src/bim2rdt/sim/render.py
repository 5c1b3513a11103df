"""The RGB-D simulator: ray cast a :class:`SiteScene` with embree (occlusion is real), shade, add sensor noise.

Depth noise is that of a time-of-flight RGB-D camera (Azure-Kinect class): axial sigma_z = 1.5 mm + 1.5 mm per
metre of depth (6 mm at 3 m). Structured-light sensors are worse at range (Nguyen, Izadi & Lovell 2012:
0.0012 + 0.0019 (z - 0.4)^2, 33 mm at 4.5 m), which would bury the 1 cm success bar in sensor noise alone.
The grey image is Lambertian under a sun-like light plus ambient, with 2 grey levels of noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bim2rdt.perception.camera import Intrinsics
from bim2rdt.sim.scene import GROUND, MISS, SiteScene, ground_albedo, texture

_LIGHT = np.array([0.35, 0.25, 0.9]) / np.linalg.norm([0.35, 0.25, 0.9])


@dataclass(frozen=True)
class RgbdFrame:
    """One rendered frame: depth (H, W) metres (NaN where nothing was hit), grey (H, W) uint8, and labels
    (H, W) int: the object index per pixel, ``GROUND`` or ``MISS``."""

    depth: np.ndarray
    gray: np.ndarray
    labels: np.ndarray
    T_world_camera: np.ndarray


def depth_sigma(z: np.ndarray) -> np.ndarray:
    """Time-of-flight axial depth noise, metres, at depth ``z`` metres."""
    return 0.0015 + 0.0015 * z


def render_rgbd(scene: SiteScene, intrinsics: Intrinsics, T_world_camera: np.ndarray,
                rng: np.random.Generator | None = None) -> RgbdFrame:
    """Render the scene from ``T_world_camera``; with ``rng``, add depth and image noise."""
    frame = cast_frame(scene, intrinsics, T_world_camera)
    return frame if rng is None else add_sensor_noise(frame, rng)


def add_sensor_noise(frame: RgbdFrame, rng: np.random.Generator) -> RgbdFrame:
    """A noisy copy of a clean frame: axial depth noise (:func:`depth_sigma`) and 2 grey levels of image noise.
    Cheap, so many noisy trials can share one ray cast."""
    depth = frame.depth + rng.normal(0.0, 1.0, frame.depth.shape) * depth_sigma(frame.depth)
    gray = np.clip(frame.gray + rng.normal(0.0, 2.0, frame.gray.shape), 0, 255).astype(np.uint8)
    return RgbdFrame(depth, gray, frame.labels, frame.T_world_camera)


def cast_frame(scene: SiteScene, intrinsics: Intrinsics, T_world_camera: np.ndarray) -> RgbdFrame:
    """The noise-free frame: one embree ray per pixel, first hit only (so occlusion is real)."""
    mesh, owner = scene.mesh()
    rays_cam = intrinsics.pixel_rays().reshape(-1, 3)
    directions = rays_cam @ T_world_camera[:3, :3].T
    origin = T_world_camera[:3, 3]
    face = mesh.ray.intersects_first(np.broadcast_to(origin, directions.shape), directions)
    hit = face >= 0
    normals = mesh.face_normals[face[hit]]
    v0 = mesh.vertices[mesh.faces[face[hit], 0]]
    depth = np.full(len(face), np.nan)
    depth[hit] = np.einsum("ni,ni->n", normals, v0 - origin) / np.einsum("ni,ni->n", normals, directions[hit])
    labels = np.full(len(face), MISS)
    labels[hit] = owner[face[hit]]
    points = origin + directions[hit] * depth[hit, None]
    gray = np.full(len(face), 200.0)  # overcast sky
    gray[hit] = 255.0 * _albedo(scene, labels[hit], points) * _lambert(normals, directions[hit])
    shape = (intrinsics.height, intrinsics.width)
    return RgbdFrame(depth.reshape(shape), np.clip(gray, 0, 255).astype(np.uint8).reshape(shape),
                     labels.reshape(shape), T_world_camera)


def _lambert(normals: np.ndarray, directions: np.ndarray) -> np.ndarray:
    facing = np.where(np.einsum("ni,ni->n", normals, directions)[:, None] > 0, -normals, normals)
    return 0.3 + 0.7 * np.clip(facing @ _LIGHT, 0.0, 1.0)


def _albedo(scene: SiteScene, labels: np.ndarray, points_world: np.ndarray) -> np.ndarray:
    albedo = np.empty(len(labels))
    ground = labels == GROUND
    albedo[ground] = ground_albedo(points_world[ground])
    for index, placed in enumerate(scene.objects):
        mine = labels == index
        T_model_world = np.linalg.inv(placed.T_world_model)
        body = points_world[mine] @ T_model_world[:3, :3].T + T_model_world[:3, 3]
        albedo[mine] = placed.albedo * texture(body)
    return albedo
