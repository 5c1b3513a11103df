"""Naming a cluster by registration: which of the BIM's families explains its points best.

A cluster is a family's object when the family's mesh, registered with SG-ICP (the family's own upright prior,
resting on the slab), puts most of the cluster's points on its surface (fitness) closely (RMSE), and when the
cluster fits inside the family's size: no view of a 70 cm cone is 1.8 m tall, whatever ICP says. Candidates
are the families the BIM places near the cluster first (a moved object rarely goes far); only when none of
them fits are all the model's families tried. A cluster no family fits is "unknown": a worker, clutter.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bim2rdt.perception.library import FamilyModel, ModelLibrary
from bim2rdt.perception.observation import UNKNOWN_FAMILY
from bim2rdt.perception.visibility import facing_fraction
from bim2rdt.registration import IcpConfig, RegistrationResult, register
from bim2rdt.semantics import DEFAULT_UPRIGHT_BIAS, UprightPrior

UP = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class NamingConfig:
    """Gates and effort of naming by registration (lengths in metres)."""

    near_radius: float = 1.5
    """BIM elements within this plan distance of a cluster are its first candidates."""
    size_margin: float = 0.12
    """A cluster may exceed a family's height or plan diagonal by this much (noise, flying pixels, a lean)."""
    min_size_fraction: float = 0.3
    """... and must span at least this fraction of the family's largest dimension."""
    min_fitness: float = 0.8
    """Fraction of the cluster's points within ``IcpConfig.score_distance`` of the registered mesh."""
    min_facing: float = 0.6
    """... and the fraction of those on model surface that faces the camera (no drum seen from behind)."""
    max_rmse: float = 0.015
    points: int = 400
    """Cluster points used to name it (a seeded subsample): naming needs the shape, not every pixel."""
    samples: int = 3000
    """Model surface samples for naming."""
    icp: IcpConfig = IcpConfig(restarts=8, max_iterations=20)


@dataclass(frozen=True)
class Naming:
    """The family a cluster was given (or ``"unknown"``), its registration, and the families tried."""

    family: str
    fit: RegistrationResult | None
    tried: tuple[str, ...] = ()

    @property
    def score(self) -> float:
        """Confidence 0-1: the fit's fitness when named; 1 - the best candidate's fitness when unknown."""
        if self.family == UNKNOWN_FAMILY:
            return 1.0 - (self.fit.fitness if self.fit is not None else 0.0)
        return float(self.fit.fitness)


def cluster_size(points_world: np.ndarray, slab_height: float) -> tuple[float, float]:
    """(height of the cluster's top above the slab, its longest plan extent), robust to a few stray points."""
    top = float(np.percentile(points_world[:, 2], 99.0)) - slab_height
    xy = points_world[:, :2] - points_world[:, :2].mean(axis=0)
    if len(xy) < 3:
        return top, 0.0
    _, vectors = np.linalg.eigh(np.cov(xy.T))
    along = xy @ vectors
    low, high = np.percentile(along, [1.0, 99.0], axis=0)
    return top, float(np.max(high - low))


def fits_size(height: float, length: float, family: FamilyModel, config: NamingConfig) -> bool:
    """Whether a cluster of this height and plan length can be a view of ``family``."""
    largest = max(family.height, family.footprint)
    return (height <= family.height + config.size_margin and length <= family.footprint + config.size_margin
            and max(height, length) >= config.min_size_fraction * largest)


def name_cluster(points_world: np.ndarray, camera: np.ndarray, slab_height: float, library: ModelLibrary,
                 priors: dict[str, UprightPrior], config: NamingConfig, seed: int = 0) -> Naming:
    """Name a cluster of world points (N, 3) seen from ``camera`` (3,): the best-fitting family among the near
    ones, else among all, else unknown (with the best failed fit, for its score)."""
    rng = np.random.default_rng(seed)
    scene = points_world[rng.permutation(len(points_world))[: config.points]]
    height, length = cluster_size(points_world, slab_height)
    centre = np.median(points_world, axis=0)
    near = library.near(centre, config.near_radius)
    near_families = list(dict.fromkeys(el.family for el in near))
    tried, failed = [], []
    for group in (near_families, [f for f in library.families if f not in near_families]):
        fits = []
        for family in group:
            model = library.families[family]
            if not fits_size(height, length, model, config):
                continue
            tried.append(family)
            fit = _facing_fit(model, scene, camera, slab_height, priors.get(family), config)
            (fits if fit is not None and _accepted(fit, config) else failed).append((family, fit))
        if fits:
            family, fit = max(fits, key=lambda f: (f[1].fitness, -f[1].rmse))
            return Naming(family, fit, tuple(tried))
    failed = [(family, fit) for family, fit in failed if fit is not None]
    best_failed = max(failed, key=lambda f: f[1].fitness)[1] if failed else None
    return Naming(UNKNOWN_FAMILY, best_failed, tuple(tried))


def _accepted(fit: RegistrationResult, config: NamingConfig) -> bool:
    return fit.fitness >= config.min_fitness and fit.rmse <= config.max_rmse


def _facing_fit(model: FamilyModel, scene: np.ndarray, camera: np.ndarray, slab_height: float,
                prior: UprightPrior | None, config: NamingConfig) -> RegistrationResult | None:
    """Register from a start set back behind the seen surface; if the fit shows the camera the model's far
    side (a mirror solution), once more from farther back. None when neither faces the camera."""
    points, normals = model.samples(config.samples)
    for setback in (0.5 * float(np.min(model.extents[:2])), 0.5 * float(np.max(model.extents[:2])) + 0.1):
        fit = _register(model, scene, _start(model, scene, camera, slab_height, setback), prior, slab_height, config)
        if facing_fraction(fit.pose, points, normals, scene, camera, tree=model.tree(config.samples)) \
                >= config.min_facing:
            return fit
    return None


def _start(model: FamilyModel, scene: np.ndarray, camera: np.ndarray, slab_height: float,
           setback: float) -> np.ndarray:
    """Where registration starts: upright on the cluster, its centre ``setback`` m behind the seen surface (a
    camera sees the front), along the surface's plan normal turned away from the camera; the yaw restarts turn
    it about its centre. Naming needs the family, not the BIM's yaw: perception registers the named object
    again from the BIM's pose."""
    centre = np.median(scene, axis=0)
    behind = _plan_normal(scene)
    away = centre[:2] - camera[:2]
    behind = behind if behind @ away >= 0 else -behind
    body_centre = model.mesh.bounds.mean(axis=0)
    T = np.eye(4)
    T[:2, 3] = centre[:2] + behind * setback - body_centre[:2]
    T[2, 3] = slab_height
    return T


def _plan_normal(points: np.ndarray) -> np.ndarray:
    """Unit (2,) direction of least spread of the points in plan: the seen surface's normal, roughly."""
    xy = points[:, :2] - points[:, :2].mean(axis=0)
    _, vectors = np.linalg.eigh(xy.T @ xy)
    return vectors[:, 0]


def _register(model: FamilyModel, scene: np.ndarray, start: np.ndarray, prior: UprightPrior | None,
              slab_height: float, config: NamingConfig) -> RegistrationResult:
    points, normals = model.samples(config.samples)
    bias = prior.upright_bias if prior else DEFAULT_UPRIGHT_BIAS
    yaw_only = prior.yaw_only if prior else False
    return register(points, normals, scene, init=start, up=UP, upright_bias=bias, yaw_only=yaw_only,
                    config=config.icp, support_height=slab_height)
