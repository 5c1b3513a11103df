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
from pydantic import BaseModel, ConfigDict

from bim2rdt.frames import UP
from bim2rdt.perception.fitting import along_long_axis, slid
from bim2rdt.perception.library import FamilyModel, ModelLibrary
from bim2rdt.perception.observation import UNKNOWN_FAMILY
from bim2rdt.perception.visibility import DepthView, see_through_fraction
from bim2rdt.registration import IcpConfig, RegistrationResult, register
from bim2rdt.semantics import DEFAULT_UPRIGHT_BIAS, UprightPrior


class NamingConfig(BaseModel):
    """Gates and effort of naming by registration (lengths in metres)."""

    model_config = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)

    near_radius: float = 1.5
    """BIM elements within this plan distance of a cluster are its first candidates."""
    size_margin: float = 0.12
    """A cluster may exceed a family's height or plan diagonal by this much (noise, flying pixels, a lean)."""
    min_size_fraction: float = 0.15
    """... and must span at least this fraction of the family's largest dimension."""
    min_fitness: float = 0.8
    """Fraction of the cluster's points within ``IcpConfig.score_distance`` of the registered mesh."""
    max_see_through: float = 0.2
    """... and at most this fraction of its visible surface may lie where the camera saw through
    (:mod:`bim2rdt.perception.visibility`: no drum seen from behind, no tripod made of a forearm)."""
    max_rmse: float = 0.015
    elsewhere_min_points: int = 150
    """A cluster named after a family the BIM has nowhere near it (an object the BIM lacks, or one moved far)
    must be this well seen (grid points) ...
    """
    elsewhere_min_span: float = 0.5
    """... and span at least this fraction of the family's largest dimension: a sliver of a beam between a
    worker's legs fits a cone as well as anything, and only the BIM's own objects nearby may explain slivers."""
    min_part_fitness: float = 0.5
    """A fit this good (and within ``max_rmse``, and consistent) names the part of a cluster it explains."""
    sure_fitness: float = 0.97
    """A family of the group being tried that fits this well is taken without trying the rest."""
    points: int = 300
    """Cluster points used to name it (a seeded subsample): naming needs the shape, not every pixel."""
    samples: int = 3000
    """Model surface samples for naming."""
    turn_deg: float = 30.0
    """The fast path also starts from the BIM pose turned this much either way (objects moved are often turned)."""
    icp: IcpConfig = IcpConfig(restarts=12, max_iterations=20)


@dataclass(frozen=True)
class Naming:
    """The family a cluster was given (or ``"unknown"``), its registration, and the families tried."""

    family: str
    fit: RegistrationResult | None
    tried: tuple[str, ...] = ()
    partial: bool = False
    """The fit explains only part of the cluster (it holds this object and something touching it)."""

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


def name_cluster(points_world: np.ndarray, view: DepthView, slab_height: float, library: ModelLibrary,
                 priors: dict[str, UprightPrior], config: NamingConfig, seed: int = 0) -> Naming:
    """Name a cluster of world points (N, 3) seen in ``view``: the best-fitting family among the near ones, else
    among all, else unknown (with the best failed fit, for its score)."""
    rng = np.random.default_rng(seed)
    scene = points_world[rng.permutation(len(points_world))[: config.points]]
    height, length = cluster_size(points_world, slab_height)
    centre = np.median(points_world, axis=0)
    near = library.near(centre, config.near_radius)
    near_families = list(dict.fromkeys(el.family for el in near))
    tried, failed = [], []
    elsewhere = [f for f in library.families if f not in near_families]
    for group in (near_families, elsewhere):
        fits, parts = [], []
        for family in group:
            model = library.families[family]
            if not fits_size(height, length, model, config) or \
                    (group is elsewhere and not _well_seen(len(points_world), height, length, model, config)):
                continue
            tried.append(family)
            homes = [el.placement for el in near if el.family == family][:1]
            fit = _from_bim(model, scene, view, homes, slab_height, priors.get(family), config) or \
                _consistent_fit(model, scene, view, slab_height, priors.get(family), config)
            bucket = fits if fit is not None and _accepted(fit, config) else \
                parts if fit is not None and _accepted_part(fit, config) else failed
            bucket.append((family, fit))
            if fit is not None and fit.fitness >= config.sure_fitness and fit.rmse <= config.max_rmse:
                break
        if fits or parts:
            family, fit = max(fits or parts, key=lambda f: (f[1].fitness, -f[1].rmse))
            return Naming(family, fit, tuple(tried), partial=not fits)
    failed = [(family, fit) for family, fit in failed if fit is not None]
    best_failed = max(failed, key=lambda f: f[1].fitness)[1] if failed else None
    return Naming(UNKNOWN_FAMILY, best_failed, tuple(tried))


def _well_seen(count: int, height: float, length: float, model: FamilyModel, config: NamingConfig) -> bool:
    largest = max(model.height, model.footprint)
    return count >= config.elsewhere_min_points and max(height, length) >= config.elsewhere_min_span * largest


def _accepted_part(fit: RegistrationResult, config: NamingConfig) -> bool:
    """A fit that explains a good part of the cluster closely: the cluster holds this object and something
    touching it (a drum left against a cone); the caller splits the rest off and names it on its own."""
    return fit.fitness >= config.min_part_fitness and fit.rmse <= config.max_rmse


def _accepted(fit: RegistrationResult, config: NamingConfig) -> bool:
    return fit.fitness >= config.min_fitness and fit.rmse <= config.max_rmse


def _from_bim(model: FamilyModel, scene: np.ndarray, view: DepthView, homes: list[np.ndarray], slab_height: float,
              prior: UprightPrior | None, config: NamingConfig) -> RegistrationResult | None:
    """The fast path: refine locally from where the BIM has the nearest element of the family, as placed, slid
    onto the cluster, and slid and turned by +-``config.turn_deg`` (most objects have not moved, or were moved
    and turned a little); None unless one of those fits."""
    points, normals = model.samples(config.samples)
    local = config.icp.model_copy(update={"restarts": 1, "yaw_jitter_deg": 0.0})
    for home in homes:
        moved = slid(home, points, scene)
        turned = [slid(_turned(home, sign * config.turn_deg, points), points, scene) for sign in (1.0, -1.0)]
        for start in (home, *along_long_axis(moved, points, scene), *turned):
            fit = _register(model, scene, start, prior, slab_height, config, local)
            if _accepted(fit, config) and see_through_fraction(fit.pose, points, normals, view) <= \
                    config.max_see_through:
                return fit
    return None


def _turned(T: np.ndarray, degrees: float, model_pts: np.ndarray) -> np.ndarray:
    """``T`` turned by ``degrees`` about the world vertical through the model's centre."""
    c, s = np.cos(np.deg2rad(degrees)), np.sin(np.deg2rad(degrees))
    turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    centre = T[:3, :3] @ model_pts.mean(axis=0) + T[:3, 3]
    out = T.copy()
    out[:3, :3] = turn @ T[:3, :3]
    out[:3, 3] = centre + turn @ (T[:3, 3] - centre)
    return out


def _consistent_fit(model: FamilyModel, scene: np.ndarray, view: DepthView, slab_height: float,
                    prior: UprightPrior | None, config: NamingConfig) -> RegistrationResult | None:
    """Register from a start behind the seen surface; if the fit stands where the camera saw through (a mirror
    solution) or fits poorly, once more from deeper behind it. The first consistent acceptable fit, else the
    best consistent one, else None."""
    points, normals = model.samples(config.samples)
    camera = view.T_world_camera[:3, 3]
    kept = None
    for depth in sorted({float(np.min(model.extents[:2])), float(np.max(model.extents[:2]))}):
        fit = _register(model, scene, _start(model, scene, camera, slab_height, depth), prior, slab_height, config)
        if see_through_fraction(fit.pose, points, normals, view) > config.max_see_through:
            continue
        if _accepted(fit, config):
            return fit
        kept = fit if kept is None or fit.fitness > kept.fitness else kept
    return kept


def _start(model: FamilyModel, scene: np.ndarray, camera: np.ndarray, slab_height: float,
           depth: float) -> np.ndarray:
    """Where registration starts: upright, its plan centre on the middle of the points along the seen surface
    and half of ``depth`` (the object's plan depth) behind the surface's front (a camera sees the near side; a
    flat object seen from above shows all of itself and is already centred); the yaw restarts turn it about
    its centre. Naming needs the family, not the BIM's yaw: perception registers the named object again from
    the BIM's pose."""
    normal = _plan_normal(scene)
    normal = normal if normal @ (np.median(scene[:, :2], axis=0) - camera[:2]) >= 0 else -normal
    tangent = np.array([-normal[1], normal[0]])
    along_t = np.percentile(scene[:, :2] @ tangent, [5.0, 95.0]).mean()
    front, back = np.percentile(scene[:, :2] @ normal, [5.0, 95.0])
    along_n = max(front + depth / 2, (front + back) / 2)
    body_centre = model.mesh.bounds.mean(axis=0)
    T = np.eye(4)
    T[:2, 3] = along_t * tangent + along_n * normal - body_centre[:2]
    T[2, 3] = slab_height
    return T


def _plan_normal(points: np.ndarray) -> np.ndarray:
    """Unit (2,) direction of least spread of the points in plan: the seen surface's normal, roughly."""
    xy = points[:, :2] - points[:, :2].mean(axis=0)
    _, vectors = np.linalg.eigh(xy.T @ xy)
    return vectors[:, 0]


def _register(model: FamilyModel, scene: np.ndarray, start: np.ndarray, prior: UprightPrior | None,
              slab_height: float, config: NamingConfig, icp: IcpConfig | None = None) -> RegistrationResult:
    points, normals = model.samples(config.samples)
    bias = prior.upright_bias if prior else DEFAULT_UPRIGHT_BIAS
    yaw_only = prior.yaw_only if prior else False
    return register(points, normals, scene, init=start, up=UP, upright_bias=bias, yaw_only=yaw_only,
                    config=icp or config.icp, support_height=slab_height)
