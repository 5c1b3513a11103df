"""The paper's four registration scenarios, rebuilt as seeded simulations.

S1-S3: the same cone / drum / crate setup seen from three viewpoints with different occlusion (S1 low front
view, the crate partly behind the cone and drum; S2 high oblique view, little occlusion; S3 side view, the drum
hiding part of the cone and the crate seen end-on). S4: poorly featured families (scaffold bay, survey tripod,
EUR pallet). Each trial jitters the camera, adds sensor noise, detects corners per object ROI, and perturbs each
object's initial pose in tilt (about a random horizontal axis), yaw and position.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bim2rdt.perception.camera import Intrinsics, look_at
from bim2rdt.registration.sampling import sample_model
from bim2rdt.registration.so3 import axis_angle
from bim2rdt.sim.meshes import mesh_for_family
from bim2rdt.sim.render import RgbdFrame, add_sensor_noise, cast_frame
from bim2rdt.sim.scene import PlacedObject, SiteScene
from bim2rdt.sim.views import object_scene_points

CONE, DRUM, CRATE = "Traffic_Cone_Orange_70cm", "Steel_Drum_55gal", "Wooden_Crate_1200x800x600"
SCAFFOLD, TRIPOD, PALLET = "Scaffold_Frame_1000x2000", "Survey_Tripod_Aluminium", "Pallet_Wood_EUR"
_TRIO = ((CONE, 0.0, 0.0, 0.3, 0.8), (DRUM, 0.9, 0.35, 1.0, 0.35), (CRATE, 0.25, 1.35, 0.4, 0.6))


@dataclass(frozen=True)
class ScenarioSpec:
    """Layout (family, x, y, yaw rad, albedo), camera eye/target (m), and the initial-pose perturbation."""

    name: str
    description: str
    layout: tuple[tuple[str, float, float, float, float], ...]
    eye: tuple[float, float, float]
    target: tuple[float, float, float]
    max_tilt_deg: float
    max_yaw_deg: float
    max_offset: float


SCENARIOS: dict[str, ScenarioSpec] = {spec.name: spec for spec in (
    ScenarioSpec("S1", "cone/drum/crate, low front view, crate partly occluded", _TRIO,
                 (0.4, -2.4, 1.0), (0.4, 0.5, 0.35), 25.0, 30.0, 0.10),
    ScenarioSpec("S2", "cone/drum/crate, high oblique view, little occlusion", _TRIO,
                 (-1.6, -1.8, 2.2), (0.4, 0.5, 0.3), 10.0, 15.0, 0.05),
    ScenarioSpec("S3", "cone/drum/crate, side view, drum hides the cone, crate end-on", _TRIO,
                 (3.0, 0.2, 1.1), (0.4, 0.6, 0.4), 25.0, 30.0, 0.10),
    ScenarioSpec("S4", "poorly featured families: scaffold bay, survey tripod, EUR pallet",
                 ((SCAFFOLD, 0.0, 0.0, 0.2, 0.5), (TRIPOD, 1.8, 0.3, 0.5, 0.7), (PALLET, 0.9, -1.3, 0.1, 0.6)),
                 (0.8, -3.4, 1.9), (0.8, 0.0, 0.7), 20.0, 30.0, 0.10),
)}


@dataclass(frozen=True)
class ObjectTrial:
    """One object of one trial: true pose, perturbed initial pose (both T_world_model) and its scene points."""

    family: str
    T_world_model: np.ndarray
    T_init: np.ndarray
    scene_pts_world: np.ndarray


@dataclass(frozen=True)
class Scenario:
    """A scenario's spec, site, model samples per family (body frame, with normals) and seeded trials."""

    spec: ScenarioSpec
    site: SiteScene
    models: dict[str, tuple[np.ndarray, np.ndarray]]
    trials: list[list[ObjectTrial]]


def scenario(name: str, trials: int = 50, seed: int = 0, sample_count: int = 2000, views: int = 5,
             intrinsics: Intrinsics = Intrinsics()) -> Scenario:
    """Build scenario ``name`` (S1-S4) with ``trials`` seeded trials; ``views`` jittered camera poses are ray
    cast once and shared by the trials (each trial draws its own sensor noise, corners and perturbations)."""
    spec = SCENARIOS[name]
    site = SiteScene([PlacedObject(family, mesh_for_family(family), _ground_pose(x, y, yaw), albedo)
                      for family, x, y, yaw, albedo in spec.layout])
    models = {o.family: sample_model(o.mesh, sample_count, seed=seed) for o in site.objects}
    rng = np.random.default_rng([seed, int(name[1:])])
    frames = [cast_frame(site, intrinsics, _jittered_camera(spec, rng)) for _ in range(views)]
    return Scenario(spec, site, models,
                    [_trial(spec, site, frames[t % views], intrinsics, rng) for t in range(trials)])


def _trial(spec: ScenarioSpec, site: SiteScene, clean: RgbdFrame, intrinsics: Intrinsics,
           rng: np.random.Generator) -> list[ObjectTrial]:
    frame = add_sensor_noise(clean, rng)
    out = []
    for index, placed in enumerate(site.objects):
        points = object_scene_points(frame, intrinsics, index, rng)
        if len(points) >= 6:
            out.append(ObjectTrial(placed.family, placed.T_world_model,
                                   perturb(placed.T_world_model, placed.mesh.centroid, spec, rng), points))
    return out


def perturb(T_true: np.ndarray, centroid_body: np.ndarray, spec: ScenarioSpec, rng: np.random.Generator):
    """An initial guess: the true pose tilted by U(0, max_tilt) about a random horizontal axis and yawed by
    U(-max_yaw, max_yaw), both about the object's centroid, then shifted by up to ``max_offset`` metres."""
    heading = rng.uniform(0.0, 2 * np.pi)
    tilt = axis_angle(np.array([np.cos(heading), np.sin(heading), 0.0]),
                      np.array(np.deg2rad(rng.uniform(0.0, spec.max_tilt_deg))))
    yaw = axis_angle(np.array([0.0, 0.0, 1.0]), np.array(np.deg2rad(rng.uniform(-1, 1) * spec.max_yaw_deg)))
    direction = rng.normal(size=3)
    centre = T_true[:3, :3] @ centroid_body + T_true[:3, 3]
    turn = tilt @ yaw
    T = np.eye(4)
    T[:3, :3] = turn @ T_true[:3, :3]
    T[:3, 3] = centre + turn @ (T_true[:3, 3] - centre)
    T[:3, 3] += direction / np.linalg.norm(direction) * rng.uniform(0.0, spec.max_offset)
    return T


def _ground_pose(x: float, y: float, yaw: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = axis_angle(np.array([0.0, 0.0, 1.0]), np.array(yaw))
    T[:3, 3] = (x, y, 0.0)
    return T


def _jittered_camera(spec: ScenarioSpec, rng: np.random.Generator) -> np.ndarray:
    eye = np.asarray(spec.eye) + rng.normal(0.0, 0.08, 3)
    return look_at(eye, np.asarray(spec.target) + rng.normal(0.0, 0.03, 3))
