"""The RGB-D simulator: ray cast a :class:`SiteScene` with embree (occlusion is real), shade, add sensor noise.

Depth noise is that of a time-of-flight RGB-D camera (Azure-Kinect class): axial sigma_z = 1.5 mm + 1.5 mm per
metre of depth (6 mm at 3 m). Structured-light sensors are worse at range (Nguyen, Izadi & Lovell 2012:
0.0012 + 0.0019 (z - 0.4)^2, 33 mm at 4.5 m), which would bury the 1 cm success bar in sensor noise alone.
The grey image is Lambertian under a sun-like light plus ambient, with 2 grey levels of noise. A scene with a
building, workers or coloured objects also gets an RGB image (the grey one is then its BT.601 luminance); a
grey-only scene renders exactly as before colour existed (the registration scenarios rely on it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bim2rdt import exact
from bim2rdt.perception.camera import Intrinsics
from bim2rdt.perception.frame import Frame
from bim2rdt.sim.scene import GROUND, MISS, STRUCTURE, WORKER, SiteScene, ground_albedo, texture
from bim2rdt.sim.surfaces import finish_albedo
from bim2rdt.sim.tof import TofEffects, amplitude, dropout_chance, mixed_depth, step_pixels, subpixel_rays

_LIGHT = np.array([0.35, 0.25, 0.9]) / exact.norm(np.array([0.35, 0.25, 0.9]))
SKY_GREY = 200.0
"""Grey level of an overcast sky (and of pixels the camera gets no return from), 0-255."""
LUMA = np.array([0.299, 0.587, 0.114])
"""ITU-R BT.601 luma weights, as :attr:`bim2rdt.perception.Frame.gray` uses."""


@dataclass(frozen=True)
class RgbdFrame:
    """One rendered frame: depth (H, W) metres (NaN where nothing was hit), grey (H, W) uint8, and labels
    (H, W) int: the object index per pixel, ``GROUND``, ``STRUCTURE``, ``WORKER`` or ``MISS``. ``rgb``
    (H, W, 3) uint8 for coloured scenes (None for grey-only ones); ``part`` (H, W) int, for building and worker
    pixels the index of the part or worker in the scene (-1 elsewhere)."""

    depth: np.ndarray
    gray: np.ndarray
    labels: np.ndarray
    T_world_camera: np.ndarray
    rgb: np.ndarray | None = None
    part: np.ndarray | None = None
    dropout: np.ndarray | None = None
    """(H, W) chance (0-1) that the sensor returns no depth there (with :class:`~bim2rdt.sim.tof.TofEffects`)."""

    @property
    def colour(self) -> np.ndarray:
        """(H, W, 3) uint8: the RGB image, or the grey one in three channels for a grey-only scene."""
        return self.rgb if self.rgb is not None else np.repeat(self.gray[..., None], 3, axis=2)

    def as_frame(self, intrinsics: Intrinsics) -> Frame:
        """What a robot would send, without the simulator's labels.

        Args:
            intrinsics: The camera's pinhole intrinsics.

        Returns:
            A :class:`~bim2rdt.perception.Frame`: RGB, float32 depth in metres (NaN = no return), the camera's
                ``T_world_camera``.
        """
        return Frame(self.colour, self.depth.astype(np.float32), intrinsics, self.T_world_camera)


def depth_sigma(z: np.ndarray) -> np.ndarray:
    """Time-of-flight axial depth noise, metres, at depth ``z`` metres."""
    return 0.0015 + 0.0015 * z


def render_rgbd(scene: SiteScene, intrinsics: Intrinsics, T_world_camera: np.ndarray,
                rng: np.random.Generator | None = None, tof: TofEffects | None = None) -> RgbdFrame:
    """Render the scene from ``T_world_camera``; with ``rng``, add depth and image noise; with ``tof``, mixed
    pixels at depth steps and dropouts (see :mod:`bim2rdt.sim.tof`).

    Args:
        scene: The scene to render.
        intrinsics: The camera's pinhole intrinsics.
        T_world_camera: The camera's pose, 4x4 camera-to-world (OpenCV axes: x right, y down, z forward).
        rng: Draws the sensor noise; None renders a clean frame.
        tof: Time-of-flight artefacts; None renders none.

    Returns:
        The frame: depth (metres), grey or RGB image, and per-pixel labels of what was hit.
    """
    frame = cast_frame(scene, intrinsics, T_world_camera, tof)
    return frame if rng is None else add_sensor_noise(frame, rng)


def add_sensor_noise(frame: RgbdFrame, rng: np.random.Generator) -> RgbdFrame:
    """A noisy copy of a clean frame: axial depth noise (:func:`depth_sigma`) and 2 grey levels of image noise
    (per channel, for an RGB frame), then the frame's dropouts, if it has any. Cheap, so many noisy trials can
    share one ray cast."""
    depth = frame.depth + rng.normal(0.0, 1.0, frame.depth.shape) * depth_sigma(frame.depth)
    if frame.rgb is None:
        gray = np.clip(frame.gray + rng.normal(0.0, 2.0, frame.gray.shape), 0, 255).astype(np.uint8)
        rgb = None
    else:
        rgb = np.clip(frame.rgb + rng.normal(0.0, 2.0, frame.rgb.shape), 0, 255).astype(np.uint8)
        gray = luminance(rgb)
    if frame.dropout is not None:
        depth[rng.random(depth.shape) < frame.dropout] = np.nan
    return RgbdFrame(depth, gray, frame.labels, frame.T_world_camera, rgb, frame.part, frame.dropout)


def luminance(rgb: np.ndarray) -> np.ndarray:
    """(H, W) uint8 BT.601 luma of an (H, W, 3) image."""
    return np.clip(exact.matmul(rgb, LUMA) + 0.5, 0, 255).astype(np.uint8)


def cast_frame(scene: SiteScene, intrinsics: Intrinsics, T_world_camera: np.ndarray,
               tof: TofEffects | None = None) -> RgbdFrame:
    """The noise-free frame: one embree ray per pixel, first hit only (so occlusion is real); with ``tof``,
    depth steps get mixed pixels and the frame carries its dropout chances (drawn by :func:`add_sensor_noise`)."""
    rays = exact.rotate(T_world_camera[:3, :3], intrinsics.pixel_rays().reshape(-1, 3))
    hits = cast_rays(scene, rays, T_world_camera[:3, 3])
    shape = (intrinsics.height, intrinsics.width)
    shade = _lambert(hits.normals, hits.directions)
    if scene.coloured:
        albedo = reflectance(scene, hits)
        rgb = np.full((hits.count, 3), SKY_GREY)
        rgb[hits.hit] = 255.0 * albedo * shade[:, None]
        rgb = np.clip(rgb + 0.5, 0, 255).astype(np.uint8).reshape(*shape, 3)
        part = np.where(np.isin(hits.labels, (STRUCTURE, WORKER)), hits.part, -1).reshape(shape)
        frame = RgbdFrame(hits.depth.reshape(shape), luminance(rgb), hits.labels.reshape(shape), T_world_camera,
                          rgb, part)
    else:
        albedo = _grey_albedo(scene, hits.labels[hits.hit], hits.points)
        gray = np.full(hits.count, SKY_GREY)
        gray[hits.hit] = 255.0 * albedo * shade
        frame = RgbdFrame(hits.depth.reshape(shape), np.clip(gray, 0, 255).astype(np.uint8).reshape(shape),
                          hits.labels.reshape(shape), T_world_camera)
    return frame if tof is None else _with_tof(frame, scene, intrinsics, hits, _ir(albedo), tof)


def _ir(albedo: np.ndarray) -> np.ndarray:
    """Near-infrared reflectance of hits, approximated by the mean of their visible reflectance."""
    return albedo.mean(axis=1) if albedo.ndim == 2 else albedo


def _with_tof(frame: RgbdFrame, scene: SiteScene, intrinsics: Intrinsics, hits: Hits, ir: np.ndarray,
              tof: TofEffects) -> RgbdFrame:
    shape = frame.depth.shape
    cos_incidence = _cos_incidence(hits.normals, hits.directions)
    depth = frame.depth.copy()
    if tof.flying_pixels:
        vs, us = np.nonzero(step_pixels(frame.depth, tof.step, tof.step_per_metre))
        depth[vs, us] = _subpixel_depth(scene, intrinsics, frame.T_world_camera, us, vs)
    dropout = None
    if tof.dropouts:
        chance = np.zeros(hits.count)
        ranges = hits.depth[hits.hit] * exact.norm(hits.directions)
        chance[hits.hit] = dropout_chance(cos_incidence, amplitude(ir, cos_incidence, ranges), tof)
        dropout = chance.reshape(shape)
    return RgbdFrame(depth, frame.gray, frame.labels, frame.T_world_camera, frame.rgb, frame.part, dropout)


def _subpixel_depth(scene: SiteScene, intrinsics: Intrinsics, T_world_camera: np.ndarray, us: np.ndarray,
                    vs: np.ndarray) -> np.ndarray:
    """Mixed depth (n,) of pixels (us, vs): 2 x 2 sub-rays, weighted by their return amplitudes."""
    rays = subpixel_rays(intrinsics, us, vs)
    hits = cast_rays(scene, exact.rotate(T_world_camera[:3, :3], rays), T_world_camera[:3, 3])
    weights = np.zeros(hits.count)
    if hits.hit.any():
        ir = _ir(reflectance(scene, hits) if scene.coloured else _grey_albedo(scene, hits.labels[hits.hit], hits.points))
        ranges = hits.depth[hits.hit] * exact.norm(hits.directions)
        weights[hits.hit] = amplitude(ir, _cos_incidence(hits.normals, hits.directions), ranges)
    return mixed_depth(hits.depth.reshape(4, -1), weights.reshape(4, -1))


def _cos_incidence(normals: np.ndarray, directions: np.ndarray) -> np.ndarray:
    return np.abs(exact.dot_rows(normals, directions)) / exact.norm(directions)


@dataclass(frozen=True)
class Hits:
    """First hits of a bundle of rays from one ``origin``: per ray (N,) ``depth`` along the ray's own scale
    (the camera z for pixel rays with z = 1; NaN for a miss), ``labels`` and ``part``; per hit (``hit`` true)
    the world ``points``, face ``normals`` and the ray ``directions``."""

    depth: np.ndarray
    labels: np.ndarray
    part: np.ndarray
    hit: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    directions: np.ndarray

    @property
    def count(self) -> int:
        return len(self.depth)


def cast_rays(scene: SiteScene, directions: np.ndarray, origin: np.ndarray) -> Hits:
    """Cast rays (N, 3) from ``origin`` (3,) into the scene; depth is the ray parameter t of the first hit."""
    mesh, owner = scene.mesh()
    face = mesh.ray.intersects_first(np.broadcast_to(origin, directions.shape), directions)
    hit = face >= 0
    normals = scene.face_normals()[face[hit]]
    v0 = mesh.vertices[mesh.faces[face[hit], 0]]
    depth = np.full(len(face), np.nan)
    depth[hit] = exact.dot_rows(normals, v0 - origin) / exact.dot_rows(normals, directions[hit])
    labels = np.full(len(face), MISS)
    labels[hit] = owner[face[hit]]
    part = np.full(len(face), -1)
    part[hit] = scene.face_parts()[face[hit]]
    points = origin + directions[hit] * depth[hit, None]
    return Hits(depth, labels, part, hit, points, normals, directions[hit])


def reflectance(scene: SiteScene, hits: Hits) -> np.ndarray:
    """Diffuse RGB reflectance (n_hit, 3), 0-1, of every hit: colour x texture of what it hit."""
    labels, parts = hits.labels[hits.hit], hits.part[hits.hit]
    out = np.empty((len(labels), 3))
    ground = labels == GROUND
    out[ground] = ground_albedo(hits.points[ground])[:, None]
    for index, placed in enumerate(scene.objects):
        mine = labels == index
        out[mine] = _body_texture(placed, hits.points[mine])[:, None] * _tint(placed)
    for index, part in enumerate(scene.building):
        mine = (labels == STRUCTURE) & (parts == index)
        out[mine] = finish_albedo(part.finish, hits.points[mine], hits.normals[mine])[:, None] * np.array(part.colour)
    for index, worker in enumerate(scene.workers):
        mine = (labels == WORKER) & (parts == index)
        out[mine] = _body_texture(worker, hits.points[mine])[:, None] * _tint(worker)
    return np.clip(out, 0.0, 1.0)


def _tint(placed) -> np.ndarray:
    return np.array(placed.colour) if placed.colour is not None else np.full(3, placed.albedo)


def _body_texture(placed, points_world: np.ndarray) -> np.ndarray:
    return texture(exact.transform(exact.inverse_pose(placed.T_world_model), points_world))


def _lambert(normals: np.ndarray, directions: np.ndarray) -> np.ndarray:
    facing = np.where(exact.dot_rows(normals, directions)[:, None] > 0, -normals, normals)
    return 0.3 + 0.7 * np.clip(exact.matmul(facing, _LIGHT), 0.0, 1.0)


def _grey_albedo(scene: SiteScene, labels: np.ndarray, points_world: np.ndarray) -> np.ndarray:
    albedo = np.empty(len(labels))
    ground = labels == GROUND
    albedo[ground] = ground_albedo(points_world[ground])
    for index, placed in enumerate(scene.objects):
        mine = labels == index
        albedo[mine] = placed.albedo * _body_texture(placed, points_world[mine])
    return albedo
