"""Registration scene families built the way a new user would build them, outside the paper's S1-S4.

S1-S4 are full site renders that the registration's defaults were tuned on. These families are the other kind
of test: one object at a time, a sparse single view of it (100-200 points taken uniformly from the surface the
camera sees), about half of it cut away by an occluder, isotropic sensor noise, uniform clutter filling the
object's bounds plus 20 cm, and a model sampled at 2,000 or 10,000 points with its bottom face kept (nobody
told the user to drop it). Starts are tilted, yawed and shifted; some families know the support the object
rests on and some do not; objects run from 0.3 m to 3 m.

F1 is a sparse scene where the choice of restart matters: a 0.6 x 0.4 x 0.5 m box, a drum (r 0.29, h 0.88 m)
and a cone (r 0.17, h 0.68 m) on a 0.36 m square plate; 2,000 samples; 150 points; 4 mm noise; 10 % clutter; starts tilted
20-35 deg, yawed +-25 deg, shifted +-5 cm; no support; upright bias 0.9. There plain ICP beat SG-ICP
(16.3 vs 21.6 mm mean surface error). The others vary one or two of those settings each.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import trimesh

from bim2rdt.frames import UP
from bim2rdt.registration.sampling import sample_model
from bim2rdt.registration.so3 import axis_angle
from bim2rdt.sim.meshes import steel_i_beam
from bim2rdt.sim.scenarios import ObjectTrial, Scenario, ScenarioError, draws

SURFACE_POOL = 20000
"""Surface samples per object from which each view draws its visible points."""


def box(extents: tuple[float, float, float]) -> Callable[[], trimesh.Trimesh]:
    """A closed box resting on z = 0, centred in x and y (body frame, m)."""
    return lambda: trimesh.creation.box(extents=extents, transform=trimesh.transformations.translation_matrix(
        (0.0, 0.0, extents[2] / 2)))


def cylinder(radius: float, height: float) -> Callable[[], trimesh.Trimesh]:
    """A closed cylinder (a drum, a bucket, a tank) standing on z = 0."""
    return lambda: trimesh.creation.cylinder(radius=radius, height=height, sections=32,
                                             transform=trimesh.transformations.translation_matrix(
                                                 (0.0, 0.0, height / 2)))


def cone_on_plate(radius: float, height: float, plate: float, plate_height: float = 0.03):
    """A cone of ``height`` (m, tip included) standing on a square plate ``plate`` m wide."""
    def build() -> trimesh.Trimesh:
        base = trimesh.creation.box(extents=(plate, plate, plate_height),
                                    transform=trimesh.transformations.translation_matrix((0, 0, plate_height / 2)))
        body = trimesh.creation.cone(radius=radius, height=height - plate_height, sections=32)
        body.apply_translation((0.0, 0.0, plate_height))
        return trimesh.util.concatenate([base, body])
    return build


@dataclass(frozen=True)
class FamilyObject:
    """One object of a family: a BIM-like family name, its mesh builder (body frame, upright +z, resting on
    z = 0) and the order of its rotational symmetry about body z (``math.inf`` = any turn, as a drum)."""

    family: str
    build: Callable[[], trimesh.Trimesh]
    symmetry_order: float


ISSUE_TRIO = (FamilyObject("Box_600x400x500", box((0.6, 0.4, 0.5)), 2),
              FamilyObject("Drum_580x880", cylinder(0.29, 0.88), math.inf),
              FamilyObject("Cone_680_on_plate_360", cone_on_plate(0.17, 0.68, 0.36), 4))
SMALL_TRIO = (FamilyObject("Box_300x200x250", box((0.3, 0.2, 0.25)), 2),
              FamilyObject("Bucket_300x300", cylinder(0.15, 0.30), math.inf),
              FamilyObject("Cone_300_on_plate_200", cone_on_plate(0.08, 0.30, 0.20), 4))
LARGE_TRIO = (FamilyObject("Timber_Stack_3000x1000x600", box((3.0, 1.0, 0.6)), 2),
              FamilyObject("Steel_I-Beam_3000", steel_i_beam, 2),
              FamilyObject("Tank_1200x2000", cylinder(0.6, 2.0), math.inf))


@dataclass(frozen=True)
class ViewFamily:
    """How a family's trials are built: objects, model density, the view (points, noise, clutter, the share
    cut away by an occluder, camera elevation), the start's perturbation, whether the support is known, the
    upright bias a user would give, and the share of trials whose object truly leans."""

    name: str
    description: str
    objects: tuple[FamilyObject, ...] = ISSUE_TRIO
    sample_count: int = 2000
    points: tuple[int, int] = (150, 150)
    noise: float = 0.004
    clutter_fraction: float = 0.10
    occluded_fraction: float = 0.5
    elevation_deg: tuple[float, float] = (10.0, 40.0)
    start_tilt_deg: tuple[float, float] = (20.0, 35.0)
    start_yaw_deg: float = 25.0
    start_shift: float = 0.05
    support: bool = False
    upright_bias: float = 0.9
    leaning_fraction: float = 0.0
    leaning_tilt_deg: tuple[float, float] = (8.0, 20.0)
    tags: tuple[str, ...] = field(default=())


FAMILIES: dict[str, ViewFamily] = {f.name: f for f in (
    ViewFamily("F1", "box/drum/cone, 2,000 samples, 150 pts, 4 mm, 10 % clutter, no support"),
    ViewFamily("F2", "F1 with models of 10,000 samples", sample_count=10000),
    ViewFamily("F3", "F1 resting on a known support", support=True),
    ViewFamily("F4", "F1 with 100 points and 2 mm noise", points=(100, 100), noise=0.002),
    ViewFamily("F5", "F1 with 200 points and 6 mm noise", points=(200, 200), noise=0.006),
    ViewFamily("F6", "0.3 m objects, 100-200 pts, 2 mm, support known", objects=SMALL_TRIO, points=(100, 200),
               noise=0.002, start_shift=0.03, support=True),
    ViewFamily("F7", "3 m objects, 100-200 pts, 6 mm, 10,000 samples", objects=LARGE_TRIO, points=(100, 200),
               noise=0.006, sample_count=10000, start_shift=0.10),
    ViewFamily("F8", "F1 from steep starts, tilted 40-60 deg", start_tilt_deg=(40.0, 60.0), tags=("tilt trap",)),
    ViewFamily("F9", "F1 where half the objects truly lean 8-20 deg (the prior is wrong)", leaning_fraction=0.5,
               sample_count=10000, support=True),
)}
"""The families ``bench registration`` runs besides S1-S4, by name."""


def family_scenario(name: str, trials: int = 50, seed: int = 0) -> Scenario:
    """Build family ``name`` with ``trials`` seeded trials (one view of each object per trial). The returned
    :class:`Scenario` has no site (views are drawn from each object alone); its ``spec`` is the
    :class:`ViewFamily`. Raises :class:`ScenarioError` on an unknown name or a trial count below 1."""
    if name not in FAMILIES:
        raise ScenarioError(f"unknown family {name!r}; choose one of {', '.join(FAMILIES)}")
    if trials < 1 or seed < 0:
        raise ScenarioError(f"trials must be >= 1 and seed >= 0, got {trials} and {seed}")
    spec = FAMILIES[name]
    meshes = {o.family: o.build() for o in spec.objects}
    models = {family: sample_model(mesh, spec.sample_count, seed=seed, drop_resting_face=False)
              for family, mesh in meshes.items()}
    pools = {family: sample_model(mesh, SURFACE_POOL, seed=seed + 1, drop_resting_face=False)
             for family, mesh in meshes.items()}
    stream = 1000 + int(name[1:])
    out = [[_object_trial(spec, o, meshes[o.family], pools[o.family], draws(seed, stream, t, index))
            for index, o in enumerate(spec.objects)] for t in range(trials)]
    return Scenario(spec, None, models, out)


def _object_trial(spec: ViewFamily, obj: FamilyObject, mesh: trimesh.Trimesh, pool, rng) -> ObjectTrial:
    leaning = rng.random() < spec.leaning_fraction
    T_true = true_pose(mesh, rng, spec.leaning_tilt_deg if leaning else None)
    pool_world = (pool[0] @ T_true[:3, :3].T + T_true[:3, 3], pool[1] @ T_true[:3, :3].T)
    count = int(rng.integers(spec.points[0], spec.points[1] + 1))
    T_init = perturbed_start(T_true, mesh.centroid, spec, rng)  # before the view, whose draws follow its ray hits
    seen = sparse_view(mesh.copy().apply_transform(T_true), pool_world, count, spec, rng)
    bounds = mesh.copy().apply_transform(T_true).bounds
    clutter = rng.uniform(bounds[0] - 0.2, bounds[1] + 0.2, (int(round(spec.clutter_fraction * len(seen))), 3))
    return ObjectTrial(obj.family, T_true, T_init, np.vstack([seen, clutter]), leaning,
                       support_height=0.0 if spec.support else None, symmetry_order=obj.symmetry_order)


def true_pose(mesh: trimesh.Trimesh, rng: np.random.Generator, lean_deg: tuple[float, float] | None) -> np.ndarray:
    """A random yaw at the origin, resting on z = 0; with ``lean_deg``, tilted by U(lean_deg) about a random
    horizontal axis and lowered to rest on its lowest point."""
    T = np.eye(4)
    T[:3, :3] = axis_angle(UP, np.array(rng.uniform(0.0, 2 * np.pi)))
    if lean_deg is not None:
        heading = rng.uniform(0.0, 2 * np.pi)
        T[:3, :3] = axis_angle(np.array([np.cos(heading), np.sin(heading), 0.0]),
                               np.array(np.deg2rad(rng.uniform(*lean_deg)))) @ T[:3, :3]
        T[2, 3] = -float(np.min(mesh.vertices @ T[2, :3]))
    return T


def sparse_view(mesh_world: trimesh.Trimesh, pool_world: tuple[np.ndarray, np.ndarray], count: int,
                spec: ViewFamily, rng: np.random.Generator) -> np.ndarray:
    """``count`` noisy points (N, 3) of the surface a camera sees: from a random azimuth and an elevation in
    ``spec.elevation_deg``, 2.5 m plus the object's size away; self-occlusion by ray casting; then the share
    ``spec.occluded_fraction`` of the visible points on one side of a vertical plane through the view ray (an
    occluder in front) is cut away."""
    points, normals = pool_world
    centre = mesh_world.bounds.mean(axis=0)
    azimuth, elevation = rng.uniform(0.0, 2 * np.pi), np.deg2rad(rng.uniform(*spec.elevation_deg))
    toward_eye = np.array([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth),
                           np.sin(elevation)])
    eye = centre + (2.5 + float(np.ptp(mesh_world.bounds, axis=0).max())) * toward_eye
    visible = _visible(mesh_world, points, normals, eye)
    lateral = (points - centre) @ np.array([-np.sin(azimuth), np.cos(azimuth), 0.0]) * rng.choice([-1.0, 1.0])
    if spec.occluded_fraction > 0.0 and visible.any():
        visible &= lateral > np.quantile(lateral[visible], spec.occluded_fraction)
    picked = rng.choice(np.flatnonzero(visible), size=min(count, int(visible.sum())), replace=False)
    return points[picked] + rng.normal(0.0, spec.noise, (len(picked), 3))


def _visible(mesh_world: trimesh.Trimesh, points: np.ndarray, normals: np.ndarray, eye: np.ndarray) -> np.ndarray:
    """Points whose surface faces the eye and whose first hit along the ray from the eye is themselves."""
    facing = np.einsum("ni,ni->n", normals, eye - points) > 0.0
    rays = points[facing] - eye
    distance = np.linalg.norm(rays, axis=1)
    hits, ray_index, _ = mesh_world.ray.intersects_location(np.broadcast_to(eye, rays.shape),
                                                            rays / distance[:, None], multiple_hits=False)
    first = np.full(len(rays), np.inf)
    first[ray_index] = np.linalg.norm(hits - eye, axis=1)
    visible = np.zeros(len(points), dtype=bool)
    visible[np.flatnonzero(facing)] = first >= distance - 1e-3
    return visible


def perturbed_start(T_true: np.ndarray, centroid_body: np.ndarray, spec: ViewFamily,
                    rng: np.random.Generator) -> np.ndarray:
    """The true pose tilted by U(start_tilt_deg) about a random horizontal axis and yawed by
    U(-start_yaw_deg, start_yaw_deg), both about the centroid, then shifted by U(-start_shift, start_shift)
    along each world axis."""
    heading = rng.uniform(0.0, 2 * np.pi)
    turn = axis_angle(np.array([np.cos(heading), np.sin(heading), 0.0]),
                      np.array(np.deg2rad(rng.uniform(*spec.start_tilt_deg)))) @ axis_angle(
        UP, np.array(np.deg2rad(rng.uniform(-1.0, 1.0) * spec.start_yaw_deg)))
    centre = T_true[:3, :3] @ centroid_body + T_true[:3, 3]
    T = np.eye(4)
    T[:3, :3] = turn @ T_true[:3, :3]
    T[:3, 3] = centre + turn @ (T_true[:3, 3] - centre) + rng.uniform(-spec.start_shift, spec.start_shift, 3)
    return T
