"""Data association of one ICP step, batched over restarts (Algorithm 1: MatchPairs, RelaxIfFew, TrimPairs,
RobustWeights).

Scene points are moved into the body frame and matched to the model's surface samples with ONE k-d tree query
for all restarts stacked (the tree over the model is built once per registration). Matching scene -> model, not
model -> scene, because a camera sees only part of the object: every scene point should lie on the model,
while most model points have no scene partner.
"""

from __future__ import annotations

import functools
import zlib
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
from pykdtree.kdtree import KDTree
from scipy.spatial import ConvexHull, QhullError, cKDTree

from bim2rdt import exact


@dataclass
class Residuals:
    """For each pose k and scene point n: the nearest model sample, the point-to-sample distance (m), the
    residual the ICP step works with (m, see :func:`plane_residual`), and a validity mask: what scoring a pose
    needs (:func:`scored_residuals`)."""

    model_index: np.ndarray  # (k, N) int
    distance: np.ndarray  # (k, N) float, inf when beyond the pair distance
    residual: np.ndarray  # (k, N) float, inf when beyond the pair distance
    valid: np.ndarray  # (k, N) bool


@dataclass
class Pairs(Residuals):
    """:class:`Residuals` with ``samples`` and ``normals``, the matched samples' points and normals (body frame),
    gathered once for the residual and the step."""

    samples: np.ndarray  # (k, N, 3) model.points[model_index]
    normals: np.ndarray  # (k, N, 3) model.normals[model_index]


SURFEL_CANDIDATES = 8
"""Nearest samples tried as the surface patch a scene point lies on (see :func:`surfel_distances`)."""
SURFEL_RADIUS = 3.0
"""Radius of each sample's surface patch, in median sample spacings (see :func:`surfel_distances`)."""
OTHER_FACE_DEG = 60.0
"""Patches whose normals differ by more belong to different faces of the object (a box's edge, 90 degrees), not to
one rounded surface (a 2.5 cm tube's neighbouring facets, 30 degrees)."""
EDGE_ANGLE_DEG = 10.0
"""Samples whose normals differ by more lie on different faces (or around a bend): one cuts the other's patch
where the surface turns away convexly. 10 degrees: a 32-sided drum's facets (11 degrees) and a 2.5 cm tripod
leg (30 degrees) count, flat faces never do."""


class SampleTree:
    """Exact nearest model samples with scipy's ``cKDTree.query`` semantics (misses at distance inf, index
    ``n``) on pykdtree's k-d tree: the same neighbours and distances, 2.5-4x faster per query (a registration's
    matching was 40-47 % of its time; ``taskset -c 0`` on an S1 model of 10,000 samples: 0.13 against 0.34 ms
    for 16 restarts x 73 points with a bound, 0.35 against 1.5 ms without).

    Args:
        points: (n, 3) the points to search, metres.
    """

    def __init__(self, points: np.ndarray):
        self.n = len(points)
        self._tree = KDTree(np.ascontiguousarray(points, dtype=np.float64))

    def query(self, points: np.ndarray, k: int = 1, distance_upper_bound: float = np.inf):
        """The ``k`` nearest samples to each of ``points``.

        Args:
            points: (N, 3) query points, metres.
            k: How many neighbours.
            distance_upper_bound: Neighbours this far or farther are misses, metres.

        Returns:
            (distances, indices): shape (N,) for k = 1, (N, k) otherwise; beyond ``distance_upper_bound``, or
                past the n-th sample, distance inf and index ``n``.
        """
        found = min(k, self.n)  # pykdtree answers garbage (2^32 - 1, 1e154) for neighbours past the n-th
        distance, index = self._tree.query(np.ascontiguousarray(points, dtype=np.float64), k=found,
                                           distance_upper_bound=distance_upper_bound)
        index = index.astype(np.intp)
        if found < k:
            pad = ((0, 0), (0, k - found))
            distance = np.pad(distance.reshape(len(points), found), pad, constant_values=np.inf)
            index = np.pad(index.reshape(len(points), found), pad, constant_values=self.n)
        return distance, index


def nearest_neighbours(points: np.ndarray, k: int) -> np.ndarray:
    """Each point's ``k`` nearest among ``points`` (itself included), nearest first: scipy's ``cKDTree.query(points,
    k=k)`` indices, found on pykdtree (~30 % faster) where that is provably the same answer: both trees sum the same
    squared distances in the same order, so without an exact tie among a row's k + 1 nearest the lists are equal;
    a call with any such tie asks scipy.

    Args:
        points: (N, 3) points, metres.
        k: Neighbours per point (at most N).

    Returns:
        (N, k) indices into ``points``.
    """
    points = np.ascontiguousarray(points, dtype=np.float64)
    asked = min(k + 1, len(points))
    squared, index = KDTree(points).query(points, k=asked, sqr_dists=True)
    squared, index = squared.reshape(len(points), asked), index.reshape(len(points), asked)
    if asked > 1 and np.any(squared[:, 1:] == squared[:, :-1]):
        _, index = cKDTree(points).query(points, k=k)
        return np.asarray(index, dtype=np.intp).reshape(len(points), k)
    return index[:, :k].astype(np.intp)


def neighbour_scatter(points: np.ndarray, index: np.ndarray) -> np.ndarray:
    """Each point's neighbourhood scatter, compiled (:func:`bim2rdt.registration.kernels.neighbour_scatter`): bit
    for bit ``local = points[index] - points[index].mean(axis=1, keepdims=True)`` and
    ``np.einsum("nki,nkj->nij", local, local)``.

    Args:
        points: (N, 3) points, metres.
        index: (n, k) each row's neighbours, indices into ``points``.

    Returns:
        (n, 3, 3) scatter matrices, m^2.
    """
    from bim2rdt.registration.kernels import neighbour_scatter as compiled  # numba's import waits for the first call

    index = np.asarray(index)
    return compiled(np.ascontiguousarray(points, dtype=np.float64), index.reshape(len(index), -1))


def smallest_axes(scatter: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The eigenvalues (ascending) and the smallest one's unit eigenvector of symmetric 3x3 matrices, in closed
    form, compiled (:func:`bim2rdt.registration.kernels.smallest_axes`): ``np.linalg.eigh``'s values and first
    column to round-off (~1e-15 of the largest eigenvalue; the vector's sign may differ), ~10x faster.

    Args:
        scatter: (n, 3, 3) symmetric matrices (a neighbourhood's scatter, :func:`neighbour_scatter`).

    Returns:
        (values (n, 3) ascending, axes (n, 3) unit): a point's normal and how flat its neighbourhood is.
    """
    from bim2rdt.registration.kernels import smallest_axes as compiled  # numba's import waits for the first call

    return compiled(np.ascontiguousarray(scatter, dtype=np.float64).reshape(-1, 3, 3))



def points_in_range(points: np.ndarray, low: float, high: float) -> np.ndarray:
    """Which rows of ``points`` are finite and lie ``low``-``high`` from the origin, compiled
    (:func:`bim2rdt.registration.kernels.in_range`): ``np.isfinite`` and ``np.linalg.norm``'s lengths, bit for bit,
    in one pass.

    Args:
        points: (N, 3) points, metres.
        low: The least length kept, metres.
        high: The greatest length kept, metres.

    Returns:
        (N,) bool, True for a row kept.
    """
    from bim2rdt.registration.kernels import in_range as compiled  # numba's import waits for the first call

    return compiled(np.ascontiguousarray(points, dtype=np.float64), float(low), float(high))


def cube_means(points: np.ndarray, voxel: float, dense_cubes: float) -> np.ndarray | None:
    """One mean point per occupied cube of side ``voxel``, cubes in ascending key order, compiled
    (:func:`bim2rdt.registration.kernels.cube_means`): a count table's numbering and ``np.bincount``'s sums, bit for
    bit.

    Args:
        points: (N, 3) points, metres.
        voxel: The cube's side, metres.
        dense_cubes: The most cubes the points' box may span for a count table.

    Returns:
        (M, 3) the cubes' mean points, metres; None when the box spans more than ``dense_cubes`` cubes.
    """
    from bim2rdt.registration.kernels import cube_means as compiled  # numba's import waits for the first call

    return compiled(np.ascontiguousarray(points, dtype=np.float64), float(voxel), float(dense_cubes))


def plane_hit_depths(face: np.ndarray, face_normals: np.ndarray, vertices: np.ndarray, faces: np.ndarray,
                     origin: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ray parameters at the plane of the triangle each ray first hit, and its unit normal, compiled
    (:func:`bim2rdt.registration.kernels.hit_depths`): t = n . (v0 - origin) / n . d, as numpy's einsum sums it.

    Args:
        face: (N,) the first triangle each ray hit, -1 for none.
        face_normals: (F, 3) the mesh's unit triangle normals.
        vertices: (V, 3) the mesh's vertices, metres.
        faces: (F, 3) the triangles' vertex indices.
        origin: (3,) the rays' origin, metres.
        directions: (N, 3) the rays' directions.

    Returns:
        (t (N,), NaN for no hit; normals (N, 3), zeros for no hit).
    """
    from bim2rdt.registration.kernels import hit_depths as compiled  # numba's import waits for the first call

    return compiled(np.ascontiguousarray(face, dtype=np.int64), np.asarray(face_normals, dtype=np.float64),
                    np.asarray(vertices, dtype=np.float64), np.asarray(faces, dtype=np.int64),
                    np.asarray(origin, dtype=np.float64), np.ascontiguousarray(directions, dtype=np.float64))

WITHIN_CUBES = 4_000_000
""":func:`any_within` grids the points' box in cubes of the radius up to this many; beyond, it asks the k-d tree."""


def any_within(points: np.ndarray, queries: np.ndarray, radius: float) -> np.ndarray:
    """Whether any of ``points`` lies nearer than ``radius`` to each of ``queries``: ``np.isfinite`` of
    :class:`SampleTree`'s bounded query, bit for bit (the same distance test, compiled over a grid of cubes:
    :func:`bim2rdt.registration.kernels.any_within`; a box of more than :data:`WITHIN_CUBES` cubes asks the tree).

    Args:
        points: (P, 3) points, metres.
        queries: (Q, 3) query points, metres.
        radius: A point this near or farther is no hit, metres.

    Returns:
        (Q,) bool.
    """
    points = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    queries = np.ascontiguousarray(queries, dtype=np.float64).reshape(-1, 3)
    if len(points) == 0 or len(queries) == 0:
        return np.zeros(len(queries), dtype=bool)
    span = np.floor((points.max(axis=0) - points.min(axis=0)) / (radius * (1.0 + 1e-6))) + 1
    if not (np.isfinite(radius) and radius > 0 and np.all(np.isfinite(span)) and np.prod(span) <= WITHIN_CUBES):
        gap, _ = SampleTree(points).query(queries, distance_upper_bound=radius)
        return np.isfinite(gap)
    from bim2rdt.registration.kernels import any_within as compiled  # numba's import waits for the first call

    return compiled(points, queries, float(radius), float(radius) * float(radius))


@dataclass(frozen=True)
class ModelIndex:
    """The model's surface samples (body frame) with normals, a k-d tree over them, their spacing (m: median
    nearest-sample distance), the radius of the surface patch each sample stands for (m), the samples on the
    convex hull (the lowest sample along any direction is one of them: the resting contact searches those only,
    ~1 % of 10,000 samples, where a search of all of them cost a tenth of a registration) with their points,
    and the samples' centroid (m, body frame).

    The hull and each sample's near list are found on first use (:attr:`extremes`, :attr:`near_ids`): only a
    registration on a support needs the hull, and only the compiled loop's warm starts the near lists (a
    k-nearest query of every sample, ~12 ms for 8,700). The localizer registers a fresh model every frame (the
    BIM surface seen from the prior) with the normal gate on, which needs neither: building them cost it ~19 ms
    a frame."""

    points: np.ndarray
    normals: np.ndarray
    tree: SampleTree
    spacing: float
    surfel_radius: float
    centroid: np.ndarray  # points.mean(axis=0)
    low: np.ndarray  # (3,) m, the samples' bounding box: least coordinates ...
    high: np.ndarray  # (3,) m ... and greatest

    @functools.cached_property
    def extremes(self) -> np.ndarray:
        """Indices of the samples on the convex hull (all of them when the samples are flat)."""
        return hull_vertices(self.points)

    @functools.cached_property
    def extreme_points(self) -> np.ndarray:
        """``points[extremes]`` (h, 3), m."""
        return self.points[self.extremes]

    @functools.cached_property
    def _near(self) -> tuple[np.ndarray, np.ndarray]:
        return near_samples(self.tree, self.points)

    @property
    def near_ids(self) -> np.ndarray:
        """(n, NEAR_SAMPLES) each sample's nearest samples, itself first."""
        return self._near[0]

    @property
    def near_radius(self) -> np.ndarray:
        """(n,) m: every sample nearer than this to a sample is in its :attr:`near_ids`."""
        return self._near[1]

    @classmethod
    def cached(cls, points: np.ndarray, normals: np.ndarray) -> ModelIndex:
        """The index of these samples, built once per content: a BIM element's model is registered again and
        again (every view, every mission), and the k-d tree over 10,000 samples costs ~2 ms, more than a tenth
        of a registration. Found by a checksum of every 64th sample and confirmed equal sample for sample
        (~20 us for 10,000; a cryptographic hash of them all cost ~0.4 ms, 3 % of a registration). The index
        keeps its own copies, so a caller changing its arrays later cannot change a cached model. Keeps the
        last :data:`INDEX_CACHE_SIZE` models."""
        key = (points.shape, normals.shape, _checksum(points), _checksum(normals))
        index = _INDEX_CACHE.get(key)
        if index is not None and np.array_equal(index.points, points) and np.array_equal(index.normals, normals):
            _INDEX_CACHE.move_to_end(key)
            return index
        index = _INDEX_CACHE[key] = cls.build(points.copy(), normals.copy())
        _INDEX_CACHE.move_to_end(key)
        if len(_INDEX_CACHE) > INDEX_CACHE_SIZE:
            _INDEX_CACHE.popitem(last=False)
        return index

    @classmethod
    def build(cls, points: np.ndarray, normals: np.ndarray, surfel_radius: float = SURFEL_RADIUS) -> ModelIndex:
        """Index the samples; the spacing is the median nearest-sample distance of up to 256 of them."""
        tree = SampleTree(points)
        spacing, _ = tree.query(points[:: max(1, len(points) // 256)], k=2)
        spacing = float(np.median(spacing[:, 1]))
        return cls(points, normals, tree, spacing, surfel_radius * spacing, points.mean(axis=0), points.min(axis=0),
                   points.max(axis=0))


NEAR_SAMPLES = 16
"""Neighbours listed per sample (itself included) for the loop's warm-started nearest-sample search
(:func:`bim2rdt.registration.kernels.warm_nearest`, decision 0045)."""


def near_samples(tree: SampleTree, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each sample's :data:`NEAR_SAMPLES` nearest samples (n, k), itself first, and the radius (n,) m within
    which the list is complete: its farthest listed neighbour's distance (a sample exactly that far may be
    missing), inf when the list holds every sample."""
    k = min(NEAR_SAMPLES, len(points))
    distance, index = tree.query(points, k=k)
    distance, index = distance.reshape(len(points), k), index.reshape(len(points), k)
    radius = np.full(len(points), np.inf) if k == len(points) else distance[:, -1].copy()
    return np.ascontiguousarray(index, dtype=np.int64), radius


def _checksum(values: np.ndarray) -> int:
    """CRC-32 of every 64th row of ``values``: a cache key, not proof of equality."""
    return zlib.crc32(np.ascontiguousarray(values[::64]).data)


def hull_vertices(points: np.ndarray) -> np.ndarray:
    """Indices of the points on their convex hull; every index when the points span no volume."""
    try:
        return np.sort(ConvexHull(points).vertices)
    except (QhullError, ValueError):
        return np.arange(len(points))


INDEX_CACHE_SIZE = 64
"""Models whose index :meth:`ModelIndex.cached` keeps (a site's families, each at one sample count)."""
_INDEX_CACHE: OrderedDict[tuple, ModelIndex] = OrderedDict()


def match_pairs(model: ModelIndex, scene_body: np.ndarray, max_distance: float) -> Pairs:
    """Nearest model sample for every scene point of every restart; pairs beyond ``max_distance`` are invalid."""
    k, n, _ = scene_body.shape
    distance, index = model.tree.query(scene_body.reshape(-1, 3), distance_upper_bound=max_distance)
    index = np.minimum(index, model.tree.n - 1).reshape(k, n)  # misses come back as tree.n; invalid anyway
    distance = distance.reshape(k, n)
    samples, normals = np.take(model.points, index, axis=0), np.take(model.normals, index, axis=0)  # ~3x fancy
    residual = plane_residual(model, scene_body, samples, normals, distance)
    return Pairs(index, distance, residual, np.isfinite(distance), samples, normals)


def scored_residuals(model: ModelIndex, scene_body: np.ndarray, max_distance: float, warm: tuple | None = None
                     ) -> Residuals:
    """:func:`match_pairs`' residuals without gathering the matched samples: the compiled
    :func:`bim2rdt.registration.kernels.pair_residuals` (the same formula as :func:`plane_residual`, to
    round-off), for callers that score poses and need no step; ``warm`` as :func:`nearest_samples` takes it."""
    from bim2rdt.registration import kernels  # numba's import waits for the first registration

    distance, index = nearest_samples(model, scene_body, max_distance, 1, warm)
    index = np.minimum(index, model.tree.n - 1)  # misses come back as tree.n; invalid anyway
    residual, _, _ = kernels.pair_residuals(scene_body, distance, index, model.points, model.normals, model.spacing,
                                            np.inf)
    return Residuals(index, distance, residual, np.isfinite(distance))


def nearest_samples(model: ModelIndex, scene_body: np.ndarray, bound: float, stride: int = 1,
                    warm: tuple | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The nearest sample (index (k, n); ``tree.n`` for a miss) of each point of ``scene_body`` (k, n, 3) and
    its distance (k, n) m (inf beyond ``bound``), the k-d tree's answer. With ``warm`` (the restarts' last
    nearest samples (K, N), updated here, and which restarts these are (k,)), the points whose last nearest
    sample proves the answer among its listed neighbours are answered so
    (:func:`bim2rdt.registration.kernels.warm_nearest`: the same samples, ~3x cheaper a point near the
    surface), the rest by the tree."""
    from bim2rdt.registration import kernels  # numba's import waits for the first registration

    k, n, _ = scene_body.shape
    if warm is None:
        distance, index = model.tree.query(scene_body.reshape(-1, 3), distance_upper_bound=bound)
        return distance.reshape(k, n), index.reshape(k, n)
    nearest, active = warm
    distance, index, cold = kernels.warm_nearest(scene_body, nearest, active, stride, model.points, model.near_ids,
                                                 model.near_radius, model.low, model.high, bound)
    if len(cold):
        far, which = model.tree.query(scene_body.reshape(-1, 3)[cold], distance_upper_bound=bound)
        distance.reshape(-1)[cold], index.reshape(-1)[cold] = far, which
    kernels.remember_nearest(nearest, active, stride, index, model.tree.n)
    return distance, index


def plane_residual(model: ModelIndex, scene_body: np.ndarray, samples: np.ndarray, normals: np.ndarray,
                   distance: np.ndarray):
    """The residual the point-to-plane step minimises, guarded: the distance of scene points to their nearest
    sample's plane (``samples``, ``normals`` (k, N, 3) the nearest samples'), but at least (point-to-sample
    distance - sample spacing), so a point far from every sample never looks close because it lies in some
    sample's plane. It weighs (Huber), trims and scores restarts: weights must see what the step minimises. It
    overestimates the distance to the surface in gaps between samples and at edges (see
    :func:`surface_distances`, which reports the fit)."""
    along_normal = np.abs(np.einsum("kni,kni->kn", normals, scene_body - samples))
    return np.maximum(along_normal, distance - model.spacing)


def surface_distances(model: ModelIndex, points: np.ndarray, max_distance: float = np.inf) -> np.ndarray:
    """Distance (N,) m of body-frame points (N, 3) to the model SURFACE (see :func:`nearest_patches`); inf
    where the surface is surely farther than ``max_distance``."""
    return nearest_patches(model, points, max_distance).distance


@dataclass(frozen=True)
class Patches:
    """Where points lie on the model surface: the distance (N,) m to the nearest sample patch, that patch's
    sample (N,), and the distance (N,) m to the nearest patch on another face (normals more than
    :data:`OTHER_FACE_DEG` apart; inf if none among the candidates). A point about as near to two faces lies
    on their edge: which face it belongs to, and so which way its residual points, is then not known."""

    distance: np.ndarray
    sample: np.ndarray
    other_face: np.ndarray


def nearest_patches(model: ModelIndex, points: np.ndarray, max_distance: float = np.inf) -> Patches:
    """The :class:`Patches` of body-frame points (N, 3) (see :func:`surfel_distances`); distances are inf where
    no sample lies within ``max_distance`` plus a patch radius (the surface is surely farther)."""
    distance, index = model.tree.query(points, k=SURFEL_CANDIDATES,
                                       distance_upper_bound=max_distance + model.surfel_radius)
    near = np.isfinite(distance[:, 0])  # the nearest candidate is first: none within reach, no patch either
    if not near.all():  # far points (clutter around an object) skip the patches' (N, c, c) work
        patches = Patches(np.full(len(points), np.inf), np.full(len(points), model.tree.n - 1),
                          np.full(len(points), np.inf))
        if near.any():
            inside = nearest_patches_of(model, points[near], distance[near], index[near])
            patches.distance[near], patches.sample[near] = inside.distance, inside.sample
            patches.other_face[near] = inside.other_face
        return patches
    return nearest_patches_of(model, points, distance, index)


def nearest_patches_of(model: ModelIndex, points: np.ndarray, distance: np.ndarray, index: np.ndarray) -> Patches:
    """:func:`nearest_patches` from the points' (N, 3) nearest candidate samples ``index`` (N, c), ``distance``
    (N, c) m away (inf = none), as the k-d tree gave them: compiled
    (:func:`bim2rdt.registration.kernels.nearest_patches`, decision 0045), :func:`nearest_patches_numpy`'s
    answer to round-off."""
    from bim2rdt.registration import kernels  # numba's import waits for the first registration

    distance_to, sample, other = kernels.nearest_patches(
        np.ascontiguousarray(points, dtype=np.float64), distance, index, model.points, model.normals,
        model.surfel_radius, np.cos(np.deg2rad(EDGE_ANGLE_DEG)), np.cos(np.deg2rad(OTHER_FACE_DEG)) - 1e-9,
        exact.TIE_TOLERANCE)
    return Patches(distance_to, sample, other)


def nearest_patches_numpy(model: ModelIndex, points: np.ndarray, distance: np.ndarray, index: np.ndarray
                          ) -> Patches:
    """:func:`nearest_patches_of` in numpy (:func:`surfel_distances`): the reference the compiled one is tested
    against."""
    to_patch, candidates = surfel_distances(model, points, index, distance)
    rows = np.arange(len(points))
    nearest = exact.first_smallest(to_patch, axis=1)  # past an edge, both faces' patches tie: the nearer sample
    normals = np.take(model.normals, candidates, axis=0)
    # "more than" with a margin: a tube's facets exactly 60 degrees apart are one surface on every machine
    across = exact.dot_rows(normals, normals[rows, nearest][:, None, :]) < np.cos(np.deg2rad(OTHER_FACE_DEG)) - 1e-9
    return Patches(to_patch[rows, nearest], candidates[rows, nearest],
                   np.where(across, to_patch, np.inf).min(axis=1))


def surfel_distances(model: ModelIndex, points: np.ndarray, candidates: np.ndarray, distance: np.ndarray):
    """Distances (N, c) m of points (N, 3) to the surface patches of their (N, c) ``candidates`` (nearest
    samples, ``distance`` (N, c) away, inf = none), and the candidates with misses clamped to valid indices:
    each sample stands for a disc of ``model.surfel_radius`` on its tangent plane, cut off where the surface
    turns away convexly. The nearest patch's distance is the point's distance to the model SURFACE.

    Why patches. Model samples are random, so a scene point on the surface is often 1-2 spacings from its
    nearest sample (a gap), and a corner on an edge is often nearest to a sample on the neighbouring face, whose
    normal is at right angles. The nearest sample's plane then puts a perfect fit cm off the surface: a crate
    at its true pose (2,000 samples, 2 mm noise) reported an RMSE of 9.7 mm. Discs of 3 spacings cover all but
    0.2 % of the surface (random samples leave a point uncovered with probability 2^-(radius/spacing)^2); a
    crate seen by a camera at its true pose then reports 2.9 mm (2,000 samples) and 2.1 mm (10,000) with
    2 mm noise, where the nearest sample's plane said 11.2 and 5.4 mm.
    A disc alone would reach past an edge and let a point up to a radius beyond it count as on the surface,
    which takes away exactly what corner points tell ICP, and would fatten a thin tube (a tripod's leg) by a
    radius; so a disc stops at the plane of any candidate where the surface turns away convexly (normals more
    than :data:`EDGE_ANGLE_DEG` apart, the disc's centre behind that plane) and a point past that edge is as
    far from the surface as from the edge.

    This residual reports the fit (RMSE, fitness, the inlier variance of the covariance and of the release
    test). The ICP step keeps pairing each point with its nearest sample: pairing it with the nearest patch
    biased the fit at edges (noise pushing a corner inside the body pairs it with the nearer face, pushing it
    outside does not, so faces are pulled inwards: an S2 crate sat 1.4 mm off its true pose, not 0.5 mm)."""
    inside = np.isfinite(distance)
    candidates = np.minimum(candidates, model.tree.n - 1)  # misses come back as tree.n; masked below
    centres, normals = np.take(model.points, candidates, axis=0), np.take(model.normals, candidates, axis=0)
    offset = points[:, None, :] - centres
    height = np.einsum("nci,nci->nc", offset, normals)  # signed, along each candidate's outward normal
    tangential = np.sqrt(np.maximum(np.einsum("nci,nci->nc", offset, offset) - height**2, 0.0))
    clip = _past_convex_edges(centres, normals, height, inside).max(axis=2)
    excess = np.maximum(np.maximum(tangential - model.surfel_radius, clip), 0.0)
    return np.where(inside, np.hypot(height, excess), np.inf), candidates


def _past_convex_edges(centres: np.ndarray, normals: np.ndarray, height: np.ndarray, inside: np.ndarray):
    """(N, c, c): for each candidate j and other candidate m where the surface turns away convexly (normals
    more than :data:`EDGE_ANGLE_DEG` apart, j's centre behind m's plane), how far the point lies past the line
    where j's and m's planes meet, measured in j's plane: (h_m - h_j cos a) / sin a for heights h above the
    planes and the angle a between them (h_m itself at a right angle); -inf otherwise. A concave crease (a
    cone on its plate) cuts nothing: there j's disc runs under the other face."""
    normals_t = np.swapaxes(normals, 1, 2)  # batched matmul: 4-6x einsum's time for (N, 8, 8) here
    cos = normals @ normals_t
    behind = centres @ normals_t - np.einsum("nmi,nmi->nm", normals, centres)[:, None, :]
    convex = (cos < np.cos(np.deg2rad(EDGE_ANGLE_DEG))) & (behind < 0.0) & inside[:, None, :]
    sin = np.sqrt(np.maximum(1.0 - cos**2, 1e-12))
    past = (height[:, None, :] - height[:, :, None] * cos) / sin
    return np.where(convex, past, -np.inf)


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
        pairs.samples[k], pairs.normals[k] = model.points[index], model.normals[index]
        pairs.residual[k] = plane_residual(model, scene_body[k:k + 1], pairs.samples[k:k + 1],
                                           pairs.normals[k:k + 1], distance[None])[0]


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
    points = np.ascontiguousarray(scene_pts, dtype=np.float64)
    _, axes = smallest_axes(neighbour_scatter(points, nearest_neighbours(points, k)))  # compiled, closed form
    return axes


def truncated_score(pairs: Residuals, truncation: float) -> np.ndarray:
    """Restart score (lower is better): mean over ALL scene points of min(r, truncation)^2 of the surface
    residual r, m^2. Unmatched points count as the truncation, so a pose that explains fewer points loses."""
    return np.mean(np.minimum(pairs.residual, truncation) ** 2, axis=1)
