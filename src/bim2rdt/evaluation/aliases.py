"""The yaw-alias scene families: sparse, half-occluded views of upright objects whose yaw aliases (a cone on a
square base, crates, pallets), where the upright prior must not pick a worse alias than plain ICP.

Each trial is one view of each object: 100-200 points, about half of the object hidden, 10 % clutter, 4 mm
noise; the start is tilted 20-35 deg about a random horizontal axis, turned +-25 deg about the vertical and
shifted +-5 cm. Two generators that share no code for the view, so a fix cannot fit one scene maker:

- ``render`` (F10): the simulator's ray caster (:func:`bim2rdt.sim.render.cast_rays`) on a site scene with the
  object on the ground and a real occluder panel between it and the camera, hiding about half of it; the points
  are uniformly drawn object pixels with axial (along-the-ray) noise, and the clutter is spurious returns in the
  object's pixel box at random depths (as a time-of-flight camera's multipath). Models of 10,000 samples of the
  simulator's own meshes (traffic cone, wooden crate, EUR pallet).
- ``mesh`` (F11): independent of the simulator's views: area-uniform samples of the posed mesh that face the
  camera (back-face culling only, no ray cast: a pallet's inner blocks show through), cut by a random
  half-space through the object's centre, isotropic noise, clutter uniform in a ball around the object. Models
  of 2,000 samples (what a new user would take) of the issue's shapes: a 0.6 x 0.4 x 0.5 m crate, a 0.68 m cone
  on a 0.36 m square plate, and the EUR pallet.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import trimesh

from bim2rdt.frames import UP
from bim2rdt.perception.camera import Intrinsics, look_at
from bim2rdt.registration.sampling import sample_model
from bim2rdt.registration.so3 import axis_angle
from bim2rdt.sim.families import box, cone_on_plate
from bim2rdt.sim.meshes import eur_pallet, traffic_cone, wooden_crate
from bim2rdt.sim.render import cast_rays
from bim2rdt.sim.scenarios import ObjectTrial, Scenario, ScenarioError, draws
from bim2rdt.sim.scene import PlacedObject, SiteScene

INTRINSICS = Intrinsics(320, 240, 262.5, 262.5, 159.5, 119.5)
"""A QVGA depth camera: enough pixels for 100-200 points per object, a quarter of the rays of VGA."""


@dataclass(frozen=True)
class AliasObject:
    """An object with yaw aliases: family name, mesh builder (body frame, upright +z, on z = 0), symmetry order
    about body z (what scoring forgives)."""

    family: str
    build: Callable[[], trimesh.Trimesh]
    symmetry_order: float


@dataclass(frozen=True)
class AliasFamily:
    """One of the yaw-alias families: its generator (``render`` | ``mesh``), objects and model density, and the
    view and start settings the issue names."""

    name: str
    description: str
    generator: str
    objects: tuple[AliasObject, ...]
    sample_count: int
    points: tuple[int, int] = (100, 200)
    noise: float = 0.004
    clutter_fraction: float = 0.10
    start_tilt_deg: tuple[float, float] = (20.0, 35.0)
    start_yaw_deg: float = 25.0
    start_shift: float = 0.05
    upright_bias: float = 0.9
    tags: tuple[str, ...] = ("aliases",)


SIM_OBJECTS = (AliasObject("Traffic_Cone_Orange_70cm", traffic_cone, 4),
               AliasObject("Wooden_Crate_1200x800x600", wooden_crate, 1),
               AliasObject("Pallet_Wood_EUR", eur_pallet, 2))
ISSUE_OBJECTS = (AliasObject("Cone_680_on_plate_360", cone_on_plate(0.17, 0.68, 0.36), 4),
                 AliasObject("Crate_600x400x500", box((0.6, 0.4, 0.5)), 2),
                 AliasObject("Pallet_Wood_EUR", eur_pallet, 2))

ALIAS_FAMILIES: dict[str, AliasFamily] = {f.name: f for f in (
    AliasFamily("F10", "aliases, rendered: cone/crate/pallet behind a panel, 100-200 px, 4 mm axial, ROI clutter",
                "render", SIM_OBJECTS, 10000),
    AliasFamily("F11", "aliases, mesh-sampled: crate, cone on a square base, pallet, half-space cut, 2,000 samples",
                "mesh", ISSUE_OBJECTS, 2000),
)}
"""The yaw-alias families by name (``bench registration`` runs them after F1-F9)."""


def alias_scenario(name: str, trials: int = 50, seed: int = 0) -> Scenario:
    """Build family ``name`` with ``trials`` seeded trials (one view of each object per trial); the returned
    :class:`Scenario` has no site, its ``spec`` is the :class:`AliasFamily`. :class:`ScenarioError` on an unknown
    name or a trial count below 1."""
    if name not in ALIAS_FAMILIES:
        raise ScenarioError(f"unknown family {name!r}; choose one of {', '.join(ALIAS_FAMILIES)}")
    if trials < 1 or seed < 0:
        raise ScenarioError(f"trials must be >= 1 and seed >= 0, got {trials} and {seed}")
    spec = ALIAS_FAMILIES[name]
    meshes = {o.family: o.build() for o in spec.objects}
    models = {family: sample_model(mesh, spec.sample_count, seed=seed, drop_resting_face=False)
              for family, mesh in meshes.items()}
    view = rendered_view if spec.generator == "render" else sampled_view
    stream = 2600 + int(name[1:])
    out = []
    for t in range(trials):
        trial = []
        for index, obj in enumerate(spec.objects):
            rng = draws(seed, stream, t, index)  # its own: a view one point off cannot shift another's draws
            mesh = meshes[obj.family]
            T_true = np.eye(4)
            T_true[:3, :3] = axis_angle(UP, np.array(rng.uniform(0.0, 2 * np.pi)))
            count = int(rng.integers(spec.points[0], spec.points[1] + 1))
            start = tilted_start(T_true, mesh.centroid, spec, rng)  # before the view: its draws follow its hits
            points = view(mesh, T_true, count, spec, rng)
            trial.append(ObjectTrial(obj.family, T_true, start, points,
                                     False, support_height=None, symmetry_order=obj.symmetry_order))
        out.append(trial)
    return Scenario(spec, None, models, out)


def rendered_view(mesh: trimesh.Trimesh, T_true: np.ndarray, count: int, spec: AliasFamily,
                  rng: np.random.Generator) -> np.ndarray:
    """``count`` object points (plus clutter) of a ray-cast view: camera at a random azimuth, 15-40 deg up,
    1.5-2.5 m plus the object's size away; a panel 40 % of the way to the camera covers one side of the object
    up to its centre line (so about half is hidden); uniform object pixels, axial noise, ROI clutter."""
    posed = mesh.copy().apply_transform(T_true)
    centre = posed.bounds.mean(axis=0)
    size = float(np.ptp(posed.bounds, axis=0).max())
    azimuth, elevation = rng.uniform(0, 2 * np.pi), np.deg2rad(rng.uniform(15.0, 40.0))
    toward_eye = np.array([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth),
                           np.sin(elevation)])
    eye = centre + (rng.uniform(1.5, 2.5) + size) * toward_eye
    T_world_camera = look_at(eye, centre)
    scene = SiteScene([PlacedObject("object", mesh, T_true), _panel(centre, eye, size, rng)], ground_size=12.0)
    rays = INTRINSICS.pixel_rays().reshape(-1, 3) @ T_world_camera[:3, :3].T
    hits = cast_rays(scene, rays, eye)
    mine = np.flatnonzero(hits.labels == 0)
    if len(mine) == 0:
        return np.zeros((0, 3))
    picked = rng.choice(mine, size=min(count, len(mine)), replace=False)
    unit = rays[picked] / np.linalg.norm(rays[picked], axis=1, keepdims=True)
    ranges = hits.depth[picked] * np.linalg.norm(rays[picked], axis=1) + rng.normal(0.0, spec.noise, len(picked))
    seen = eye + unit * ranges[:, None]
    return np.vstack([seen, _roi_clutter(mine, rays, eye, hits.depth, spec.clutter_fraction * len(seen), rng)])


def _panel(centre: np.ndarray, eye: np.ndarray, size: float, rng: np.random.Generator) -> PlacedObject:
    """A 5 cm thick panel standing 40 % of the way from the object to the camera, reaching from beside the object
    to its centre line as the camera sees it (the side is random), as tall as the view line over the object."""
    toward = (eye - centre) * np.array([1.0, 1.0, 0.0])
    toward /= np.linalg.norm(toward)
    lateral = np.array([-toward[1], toward[0], 0.0]) * rng.choice([-1.0, 1.0])
    at = centre + 0.4 * np.linalg.norm((eye - centre)[:2]) * toward
    shrink = 0.6  # the panel is nearer the camera: its edge through the view line hides about half the object
    width = 1.5 * size
    middle = at + lateral * shrink * width / 2
    T = np.eye(4)
    T[:3, :3] = np.column_stack([lateral, toward, UP])
    T[:3, 3] = (middle[0], middle[1], 0.0)
    height = 2.0 * size + 0.5 * eye[2]
    return PlacedObject("occluder", trimesh.creation.box(
        extents=(shrink * width, 0.05, height), transform=trimesh.transformations.translation_matrix(
            (0.0, 0.0, height / 2))), T)


def _roi_clutter(pixels: np.ndarray, rays: np.ndarray, eye: np.ndarray, depth: np.ndarray, count: float,
                 rng: np.random.Generator) -> np.ndarray:
    """Spurious returns: random pixels of the object's pixel box at depths spread 0.3 m around its own."""
    n = int(round(count))
    if n == 0:
        return np.zeros((0, 3))
    width = INTRINSICS.width
    us, vs = pixels % width, pixels // width
    u = rng.integers(us.min(), us.max() + 1, n)
    v = rng.integers(vs.min(), vs.max() + 1, n)
    z = rng.uniform(np.nanmin(depth[pixels]) - 0.3, np.nanmax(depth[pixels]) + 0.3, n)
    return eye + rays[v * width + u] * z[:, None]


def sampled_view(mesh: trimesh.Trimesh, T_true: np.ndarray, count: int, spec: AliasFamily,
                 rng: np.random.Generator) -> np.ndarray:
    """``count`` points (plus clutter) of a view built without the simulator's renderer: area-uniform surface
    samples of the posed mesh facing a camera at a random azimuth, 10-45 deg up; those on the hidden side of a
    random plane through the object's centre (its normal within 60 deg of the camera's lateral axis, so about
    half is cut) are dropped; isotropic noise; clutter uniform in the ball around the object 0.2 m wider."""
    posed = mesh.copy().apply_transform(T_true)
    points, faces = trimesh.sample.sample_surface(posed, 20 * count, seed=int(rng.integers(2**31)))
    normals = posed.face_normals[faces]
    centre = posed.bounds.mean(axis=0)
    azimuth, elevation = rng.uniform(0, 2 * np.pi), np.deg2rad(rng.uniform(10.0, 45.0))
    toward_eye = np.array([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth),
                           np.sin(elevation)])
    facing = np.einsum("ni,ni->n", normals, centre + 3.0 * toward_eye - points) > 0.0
    turn = azimuth + np.pi / 2 + np.deg2rad(rng.uniform(-60.0, 60.0))
    kept = facing & ((points - centre) @ np.array([np.cos(turn), np.sin(turn), 0.0]) > 0.0)
    picked = rng.choice(np.flatnonzero(kept), size=min(count, int(kept.sum())), replace=False)
    seen = points[picked] + rng.normal(0.0, spec.noise, (len(picked), 3))
    radius = 0.5 * float(np.linalg.norm(np.ptp(posed.bounds, axis=0))) + 0.2
    n = int(round(spec.clutter_fraction * len(seen)))
    direction = rng.normal(size=(n, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    clutter = centre + direction * radius * np.cbrt(rng.random(n))[:, None]
    return np.vstack([seen, clutter])


def tilted_start(T_true: np.ndarray, centroid_body: np.ndarray, spec: AliasFamily,
                 rng: np.random.Generator) -> np.ndarray:
    """The true pose turned by U(-start_yaw, start_yaw) about the vertical and tilted by U(start_tilt) about a
    random horizontal axis, both through the centroid, then shifted by U(-start_shift, start_shift) per axis."""
    heading = rng.uniform(0.0, 2 * np.pi)
    turn = axis_angle(np.array([math.cos(heading), math.sin(heading), 0.0]),
                      np.array(np.deg2rad(rng.uniform(*spec.start_tilt_deg)))) @ axis_angle(
        UP, np.array(np.deg2rad(rng.uniform(-1.0, 1.0) * spec.start_yaw_deg)))
    centre = T_true[:3, :3] @ centroid_body + T_true[:3, 3]
    T = np.eye(4)
    T[:3, :3] = turn @ T_true[:3, :3]
    T[:3, 3] = centre + turn @ (T_true[:3, 3] - centre) + rng.uniform(-spec.start_shift, spec.start_shift, 3)
    return T
