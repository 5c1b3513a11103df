"""Data association of one ICP step, batched over restarts (Algorithm 1: MatchPairs, RelaxIfFew, TrimPairs,
RobustWeights).

Scene points are moved into the body frame and matched to the model's surface samples with ONE k-d tree query
for all restarts stacked (the tree over the model is built once per registration). Matching scene -> model, not
model -> scene, because a camera sees only part of the object: every scene point should lie on the model,
while most model points have no scene partner.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree


@dataclass
class Pairs:
    """For each restart k and scene point n: the nearest model sample, the point-to-sample distance (m), the
    estimated distance to the model SURFACE (m, see :func:`surface_residual`), and a validity mask."""

    model_index: np.ndarray  # (k, N) int
    distance: np.ndarray  # (k, N) float, inf when beyond the pair distance
    residual: np.ndarray  # (k, N) float, inf when beyond the pair distance
    valid: np.ndarray  # (k, N) bool


@dataclass(frozen=True)
class ModelIndex:
    """The model's surface samples (body frame) with normals, a k-d tree over them, and their spacing (m)."""

    points: np.ndarray
    normals: np.ndarray
    tree: cKDTree
    spacing: float

    @classmethod
    def build(cls, points: np.ndarray, normals: np.ndarray) -> ModelIndex:
        """Index the samples; the spacing is the median nearest-sample distance of up to 256 of them."""
        tree = cKDTree(points)
        spacing, _ = tree.query(points[:: max(1, len(points) // 256)], k=2)
        return cls(points, normals, tree, float(np.median(spacing[:, 1])))


def match_pairs(model: ModelIndex, scene_body: np.ndarray, max_distance: float) -> Pairs:
    """Nearest model sample for every scene point of every restart; pairs beyond ``max_distance`` are invalid."""
    k, n, _ = scene_body.shape
    distance, index = model.tree.query(scene_body.reshape(-1, 3), distance_upper_bound=max_distance)
    index = np.minimum(index, model.tree.n - 1).reshape(k, n)  # misses come back as tree.n; invalid anyway
    distance = distance.reshape(k, n)
    residual = surface_residual(model, scene_body, index, distance)
    return Pairs(index, distance, residual, np.isfinite(distance))


def surface_residual(model: ModelIndex, scene_body: np.ndarray, index: np.ndarray, distance: np.ndarray):
    """Distance of scene points to the model surface, not to its nearest sample: the point-to-plane distance
    along the sample's normal, but at least (point-to-sample distance - sample spacing). With 2,000 samples on a
    crate the samples are ~5 cm apart, so raw sample distances (~2 cm on a perfect fit) would swamp a 1 cm
    Huber scale and the score; this estimate is ~0 on a perfect fit and still grows off the surface."""
    along_normal = np.abs(np.einsum("kni,kni->kn", model.normals[index], scene_body - model.points[index]))
    return np.maximum(along_normal, distance - model.spacing)


def gate_normals(pairs: Pairs, scene_normals_body: np.ndarray, model_normals: np.ndarray, gate_deg: float) -> None:
    """Invalidate pairs whose model normal and (unsigned, PCA) scene normal differ by more than ``gate_deg``."""
    if gate_deg >= 90.0:
        return
    cos = np.abs(np.einsum("kni,kni->kn", scene_normals_body, model_normals[pairs.model_index]))
    pairs.valid &= cos >= np.cos(np.deg2rad(gate_deg))


def relax_if_few(pairs: Pairs, model: ModelIndex, scene_body: np.ndarray, min_pairs: int,
                 wider_distance: float) -> None:
    """Restarts left with fewer than ``min_pairs`` pairs are re-matched without the normal gate, first within
    ``wider_distance`` (the configured maximum, when the loop has shrunk it), then with no bound at all: a step
    on all data beats no step (the pose is far off, or the view is tiny)."""
    for k in np.flatnonzero(pairs.valid.sum(axis=1) < min_pairs):
        for bound in (wider_distance, np.inf):
            distance, index = model.tree.query(scene_body[k], distance_upper_bound=bound)
            found = np.isfinite(distance)
            if found.sum() >= min_pairs:
                break
        index = np.minimum(index, model.tree.n - 1)
        pairs.model_index[k], pairs.distance[k], pairs.valid[k] = index, distance, found
        pairs.residual[k] = surface_residual(model, scene_body[k:k + 1], index[None], distance[None])[0]


def trim_pairs(pairs: Pairs, residual: np.ndarray, trim_fraction: float, min_pairs: int,
               keep_within: float = 0.0) -> None:
    """Drop the ``trim_fraction`` of each restart's valid pairs with the largest ``residual`` (k, N), never
    below ``min_pairs`` and never a pair within ``keep_within`` metres. The floor matters on partial views: the
    pairs farthest off are often the ones that still pull the model into place, and trimming them all would
    freeze a half-way fit; only residuals well beyond the robust scale are treated as clutter."""
    if trim_fraction <= 0.0:
        return
    counts = pairs.valid.sum(axis=1)
    keep = np.maximum(np.ceil((1.0 - trim_fraction) * counts), np.minimum(min_pairs, counts)).astype(int)
    ordered = np.sort(np.where(pairs.valid, residual, np.inf), axis=1)
    cutoff = np.maximum(ordered[np.arange(len(keep)), np.maximum(keep - 1, 0)], keep_within)
    pairs.valid &= residual <= cutoff[:, None]


def huber_weights(pairs: Pairs, residual: np.ndarray, delta: float) -> np.ndarray:
    """IRLS weights of the Huber loss: 1 where ``residual`` <= ``delta`` (m), delta/r beyond; 0 if invalid."""
    distance = np.where(pairs.valid, residual, 0.0)
    weights = np.where(distance <= delta, 1.0, delta / np.maximum(distance, 1e-12))
    return np.where(pairs.valid, weights, 0.0)


def annealed_delta(iteration: int, start: float, final: float, iterations: int) -> float:
    """Huber scale shrinking geometrically from ``start`` to ``final`` over ``iterations`` steps (then flat).
    A wide scale first keeps the basin (robust weights slow convergence far from the optimum), a tight one last
    rejects clutter."""
    if iterations <= 0 or iteration >= iterations or start <= final:
        return final
    return float(start * (final / start) ** (iteration / iterations))


def scene_normals(scene_pts: np.ndarray, neighbours: int) -> np.ndarray:
    """Unsigned unit normals of scene points from PCA of their nearest neighbours (smallest eigenvector)."""
    k = min(neighbours, len(scene_pts))
    _, index = cKDTree(scene_pts).query(scene_pts, k=k)
    local = scene_pts[index] - scene_pts[index].mean(axis=1, keepdims=True)
    _, vectors = np.linalg.eigh(np.einsum("nki,nkj->nij", local, local))
    return vectors[:, :, 0]


def truncated_score(pairs: Pairs, truncation: float) -> np.ndarray:
    """Restart score (lower is better): mean over ALL scene points of min(r, truncation)^2 of the surface
    residual r, m^2. Unmatched points count as the truncation, so a pose that explains fewer points loses."""
    return np.mean(np.minimum(pairs.residual, truncation) ** 2, axis=1)
