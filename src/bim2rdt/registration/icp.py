"""Semantic-Gravity ICP (the paper's Algorithm 1) as one loop; plain robust ICP is ``upright_bias=0``.

Every restart of one registration advances together: the scene is moved into each restart's body frame, all of
them are matched with one k-d tree query, weighted, and solved with batched 3x3 (or 6x6) systems. Restarts that
converge stop; restarts far behind the best after ``prune_after`` iterations are dropped.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field, replace

import numpy as np

from bim2rdt.frames import UP_BODY
from bim2rdt.registration import matching
from bim2rdt.registration.config import IcpConfig
from bim2rdt.registration.fit import report_fit
from bim2rdt.registration.so3 import axis_angle, invert_poses, rotation_angle, tilt_angle
from bim2rdt.registration.solvers import DEGENERATE_RATIO, SOLVERS, gravity_weight
from bim2rdt.registration.uncertainty import PoseUncertainty
from bim2rdt.registration.validation import Problem, validate_problem

@dataclass(frozen=True)
class RegistrationResult:
    """The best restart's pose and its fit. ``rmse`` (m) and ``fitness`` (0-1) are over scene points within
    ``IcpConfig.score_distance`` of the posed model's SURFACE; ``score`` is the truncated mean squared
    residual (m^2, plus the upright penalty under a bias) that chose the restart; ``uncertainty`` the pose
    covariance and what the view leaves unconstrained (see :mod:`bim2rdt.registration.uncertainty`). A
    registration asked for no report (``register(..., report=False)``) leaves ``rmse`` and ``fitness`` NaN and
    ``uncertainty`` None."""

    pose: np.ndarray  # T_world_model (4, 4)
    rmse: float
    fitness: float
    iterations: int
    score: float
    restart: int
    converged: bool
    tilt_deg: float
    total_iterations: int
    restart_scores: tuple[float, ...] = field(default=())
    released: bool = False  # the data showed a lean strongly enough to overrule the upright prior
    uncertainty: PoseUncertainty | None = None

    @property
    def covariance(self) -> np.ndarray:
        """(6, 6) pose covariance in :data:`bim2rdt.registration.uncertainty.POSE_PARAMETERS` order: rotation
        (rad) about world x, y, z through the model's centroid, then the centroid's shift (m) along them."""
        return self.uncertainty.covariance

    @property
    def unobservable(self) -> np.ndarray:
        """(k, 6) unit directions (rotation scaled by ``uncertainty.length``, then translation) that the view
        leaves unconstrained, weakest first; empty (0, 6) when the view pins every direction down."""
        return self.uncertainty.unobservable


@dataclass
class _Restarts:
    """State of all restarts of one registration."""

    poses: np.ndarray  # (K, 4, 4) T_world_model
    iterations: np.ndarray  # (K,)
    scores: np.ndarray  # (K,) latest truncated score
    done: np.ndarray  # (K,) converged
    pruned: np.ndarray  # (K,) dropped as losing
    nearest: np.ndarray | None = None  # (K, N) each scene point's last nearest sample, -1 none (warm starts)

    @classmethod
    def start(cls, poses: np.ndarray) -> _Restarts:
        k = len(poses)
        return cls(poses, np.zeros(k, int), np.full(k, np.inf), np.zeros(k, bool), np.zeros(k, bool))

    def active(self) -> np.ndarray:
        return np.flatnonzero(~self.done & ~self.pruned)

    def prune(self, ratio: float, keep: int, group: slice = slice(None)) -> None:
        """Drop restarts whose score is worse than ``ratio`` x the best so far (converged ones included), and all
        but the ``keep`` best of the rest; among the restarts of ``group`` only (all by default)."""
        pruned, scores = self.pruned[group], self.scores[group]  # views: pruning them prunes self
        alive = ~pruned
        best = scores[alive].min()
        pruned |= alive & (scores > ratio * best + 1e-12)
        survivors = np.flatnonzero(~pruned)
        pruned[survivors[np.argsort(scores[survivors], kind="stable")[keep:]]] = True

    def part(self, group: slice) -> _Restarts:
        """The restarts of ``group``, as their own state."""
        return _Restarts(self.poses[group], self.iterations[group], self.scores[group], self.done[group],
                         self.pruned[group], None if self.nearest is None else self.nearest[group])


def register(model_points: np.ndarray, model_normals: np.ndarray, scene_points: np.ndarray,
             init: np.ndarray = np.eye(4), up: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 1.0),
             upright_bias: float = 0.0, yaw_only: bool = False, config: IcpConfig | None = None,
             support_height: float | None = None, *, report: bool = True) -> RegistrationResult:
    """Align a model (body-frame surface samples with normals, upright along +z) to scene points (world frame).

    SG-ICP: yaw restarts and hops around the best, with the gravity prior pulling the model's up axis onto the
    measured ``up`` in proportion to ``upright_bias`` (0 = plain point-to-plane ICP).

    Args:
        model_points: (N,3) surface samples of the model in its body frame, metres (see :func:`sample_model`).
        model_normals: (N,3) unit outward normals of those samples, body frame.
        scene_points: (M,3) observed points in the world frame (z-up), metres.
        init: The initial pose ``T_world_model``, 4x4 model-to-world, metres.
        up: The measured world up (against gravity), a unit 3-vector in the world frame.
        upright_bias: The family's prior of standing upright, in [0, 1].
        yaw_only: Keep the roll and pitch of ``init`` and fit yaw and position only.
        config: The search's settings; None uses :class:`IcpConfig`'s defaults.
        support_height: Height (metres along ``up``) of the slab the object rests on; its lowest point is pulled
            onto it (a body at rest touches its support). None leaves height free.
        report: Report the fit on the final pose (``rmse``, ``fitness``, ``uncertainty``: ~30 % of a
            registration's time). False, for a caller that reads only the pose and the score, leaves ``rmse``
            and ``fitness`` NaN and ``uncertainty`` None; the pose and the score are the same either way.

    Returns:
        The fit: ``pose`` (``T_world_model``, 4x4), ``fitness`` (0-1), ``rmse`` (metres), the ``score`` that
            chose the restart and the pose ``uncertainty`` (see ``report``).

    Raises:
        RegistrationError: Bad input (shapes, non-finite values, too few points, a non-rigid ``init``, an
            ``upright_bias`` outside [0, 1]).
    """
    cfg = config or IcpConfig()
    problem = validate_problem(model_points, model_normals, scene_points, init, up, upright_bias, support_height)
    model = matching.ModelIndex.cached(problem.model_pts_body, problem.model_normals_body)
    normals_world = matching.scene_normals(problem.scene_pts_world, cfg.scene_normal_neighbours) \
        if cfg.normal_gate_deg < 90.0 else None
    if problem.upright_bias > 0.0 and not yaw_only and cfg.prior_free_pass:
        best = _with_prior_free_pass(problem, model, normals_world, cfg)
    else:
        best = _restarts_and_hops(problem, model, normals_world, cfg, yaw_only)
    if 0.0 < problem.upright_bias < 1.0 and not yaw_only and cfg.release_iterations > 0:
        best = _release_if_leaning(best, problem, model, normals_world, cfg)
    if not report:
        return best
    return _with_fit(best, problem, model, cfg, yaw_only)  # (no prior, a certain one, or yaw_only: no release)


def load_kernels() -> None:
    """Load the compiled ICP step (:mod:`bim2rdt.registration.kernels`) now: numba's import and each kernel's
    cached machine code cost ~0.4 s of one core once per process, which the first registration would otherwise
    pay. A long run (``verify``) calls this in its setup so its first frame costs what the others do. Two small
    registrations of a box's corner do it, yaw-only on a support and under an upright prior (the paths verify
    takes, the second with its fit report), the scene normals' scatter and axes, the bounded any-point test,
    the scan's range test and cube means, and the ray casts' hit depths; no result is kept."""
    grid = np.linspace(0.0, 0.4, 8)
    u, v = (a.ravel() for a in np.meshgrid(grid, grid))
    zero = np.zeros_like(u)
    faces = [np.c_[u, v, zero], np.c_[u, zero, v], np.c_[zero, u, v]]
    points = np.concatenate(faces)
    normals = np.repeat(np.array([[0.0, 0.0, -1.0], [0.0, -1.0, 0.0], [-1.0, 0.0, 0.0]]), len(u), axis=0)
    scene = points + np.array([0.01, -0.01, 0.0])
    register(points, normals, scene, yaw_only=True, support_height=0.0, report=False)
    register(points, normals, scene, upright_bias=0.5)  # with the fit report (its surface patches' kernel)
    matching.scene_normals(scene, 8)  # the normals' scatter kernel (the localizer's scan and gated pairs use it)
    matching.any_within(points, scene, 0.05)  # which lattice directions a view covers (the localizer's)
    from bim2rdt.registration import kernels

    kernels.in_range(scene, 0.0, 1.0)  # a scan's returns in range, and their cube means (the localizer's)
    kernels.cube_means(scene, 0.05, 1e6)
    kernels.hit_depths(np.array([0, -1]), normals[:1], points[:3], np.array([[0, 1, 2]]), np.zeros(3), scene[:2])


RIVAL_DEGREES = 3.0
"""A prior-free search whose kept pose is within 1 cm and this many degrees of the prior's is in the prior's basin
(the prior levels a 1-3 degree tilt fitted to noise on sparse views); it stops there."""


def _restarts_and_hops(problem: Problem, model: matching.ModelIndex, normals_world: np.ndarray | None,
                       cfg: IcpConfig, yaw_only: bool) -> RegistrationResult:
    """Algorithm 1's search under ``problem``'s bias: yaw restarts from the (levelled) start, the kept one
    (:func:`pick_restart`), and hops around it when fewer than ``hop_unless_agreeing`` restarts agree."""
    restarts = _search(_restart_starts(problem, model, cfg, yaw_only), problem, model, normals_world, cfg, yaw_only)
    best = _keep_best(restarts, problem, model, cfg)
    if _should_hop(restarts, best, model, cfg):
        best = hop(best, problem, model, normals_world, cfg, yaw_only)
    return best


def _should_hop(restarts: _Restarts, best: RegistrationResult, model: matching.ModelIndex, cfg: IcpConfig) -> bool:
    """Whether to hop around ``best``: fewer than ``hop_unless_agreeing`` surviving restarts ended there (and
    there was more than one restart, see :func:`hop`)."""
    return cfg.restarts > 1 and agreeing(restarts, best.pose, model.centroid) < cfg.hop_unless_agreeing


def _restart_starts(problem: Problem, model: matching.ModelIndex, cfg: IcpConfig, yaw_only: bool) -> np.ndarray:
    """The restarts' initial poses (K, 4, 4) under ``problem``'s bias: yaw turns of the (levelled) start."""
    start = level_towards_up(problem.T_world_model_init, model.centroid, problem.up_world,
                             0.0 if yaw_only else problem.upright_bias * cfg.start_leveling)
    return yaw_restarts(start, model.centroid, problem.up_world, cfg)


def _with_prior_free_pass(problem: Problem, model: matching.ModelIndex, normals_world: np.ndarray | None,
                          cfg: IcpConfig) -> RegistrationResult:
    """The prior's search (:func:`_restarts_and_hops`) and plain ICP's from the same restarts (no prior, no
    levelled start: exactly what ``upright_bias=0`` runs), then :func:`keep_data_choice` between their results.
    When ICP's kept restart ended in the basin of the prior's result (within 1 cm and ``RIVAL_DEGREES``: only
    the tilt the prior levels differs), the prior's result stands and ICP does not hop.

    The same two searches, batched: both searches' restarts run as one batch (:func:`_search_together`), and
    when both would hop, their hop rounds run as one batch too (:func:`_hop_together`) unless ICP's kept
    restart is already in the prior's kept restart's basin; ICP's hops are then thrown away if the prior's hops
    ended in its basin after all (the rule above), so every result is what the searches run one after the
    other gave, at one loop's per-call overhead (most of an iteration's time) instead of two."""
    free_problem = replace(problem, upright_bias=0.0)
    searched = _search_together([problem, free_problem], model, normals_world, cfg)
    kept = [_keep_best(restarts, p, model, cfg) for restarts, p in zip(searched, (problem, free_problem))]
    hopping = [_should_hop(restarts, best, model, cfg) for restarts, best in zip(searched, kept)]

    def in_basin(pose: np.ndarray) -> bool:  # ICP's kept restart, in the basin of a pose of the prior's
        return bool(near(kept[1].pose[None], pose, model.centroid, degrees=RIVAL_DEGREES)[0])

    free = None
    if all(hopping) and not in_basin(kept[0].pose):
        prior, free = _hop_together(kept, [problem, free_problem], model, normals_world, cfg)
    else:
        prior = hop(kept[0], problem, model, normals_world, cfg, False) if hopping[0] else kept[0]
    if in_basin(prior.pose):
        return prior
    if free is None:
        free = hop(kept[1], free_problem, model, normals_world, cfg, False) if hopping[1] else kept[1]
    return keep_data_choice(prior, free, problem, model, normals_world, cfg)


def keep_data_choice(prior: RegistrationResult, free: RegistrationResult, problem: Problem,
                     model: matching.ModelIndex, normals_world: np.ndarray | None, cfg: IcpConfig
                     ) -> RegistrationResult:
    """The prior's result, or plain ICP's polished with the prior (:func:`_polish`), as :func:`data_choice`
    says, against ICP's pose after the polish that keeps it (the prior levels it within its basin, so a tilt
    of a degree or two fitted to noise is not held against ICP's basin), unless the data clearly prefer ICP's
    pose as found (a truly leaning object: the polish takes part of its lean, the release test gives it back).
    Both on the distance of the scene points to the model SURFACE (:func:`surface_terms`: what the fit
    reports, not the nearest sample's plane the step works with, which at 2,000 samples is dominated by the
    gaps between samples) plus the upright penalty. The prior's result is kept only when that objective
    prefers it beyond the data's paired noise and the data do not clearly prefer ICP's (:func:`prior_kept`): a
    prior that knows how an object stands, not which yaw or slide alias a sparse view shows, changes the basin
    only through the tilt it knows. On a tie the initial guess decides when one side left the loop's reach
    (:func:`guess_decides`)."""
    polished = _polish(free.pose, problem, model, normals_world, cfg)
    pose = polished.poses[0]
    poses = np.stack([prior.pose, pose, free.pose])
    scores, pairs = score_poses(model, poses, problem.scene_pts_world, cfg)
    penalties = upright_penalty(poses, pairs, problem, cfg)
    per_point = surface_terms(model, poses, problem.scene_pts_world, cfg)
    total = prior.total_iterations + free.total_iterations + int(polished.iterations[0])
    if prior_kept(per_point, penalties, cfg.tie_sigmas) or guess_decides(
            per_point, penalties, beyond_reach(poses[:2], problem, model.centroid, cfg.max_pair_distance),
            cfg.tie_sigmas):
        return replace(prior, total_iterations=total)
    return replace(free, pose=pose.copy(), iterations=free.iterations + int(polished.iterations[0]),
                   score=float(scores[1] + penalties[1]),
                   tilt_deg=float(np.rad2deg(tilt_angle(pose[:3, :3], problem.up_world))), total_iterations=total)


def guess_decides(per_point: np.ndarray, penalties: np.ndarray, beyond: np.ndarray, sigmas: float) -> bool:
    """Whether the initial guess keeps the prior's pose where the data tie: from the per-point data terms (3, N)
    (m^2) and upright penalties (3,) of the prior's pose, ICP's pose polished with the prior and ICP's pose as
    found (as :func:`prior_kept` takes them), and whether the first two are beyond the loop's reach of the
    guess (2,) (:func:`beyond_reach`). True when ICP's polished pose is beyond reach and the prior's is not,
    and neither ICP's polished pose (data plus penalty) nor its pose as found (data) scores lower than the
    prior's by more than ``sigmas`` standard errors. The loop matches no pair farther than
    ``max_pair_distance``: it presumes the guess (the BIM's pose, or the last one) within that distance of the
    object, and a pose that carried the object farther away contradicts the one thing known about where it
    is, when the view cannot tell the two poses apart."""
    if not beyond[1] or beyond[0]:
        return False
    return not (prior_beats_data(per_point[[1, 0]], sigmas, penalties[[1, 0]])
                or prior_beats_data(per_point[[2, 0]], sigmas))


def beyond_reach(poses: np.ndarray, problem: Problem, centroid_body: np.ndarray, reach: float) -> np.ndarray:
    """(K,) whether each pose (K, 4, 4) puts the model's centroid farther than ``reach`` (m) from where the
    initial guess ``problem.T_world_model_init`` puts it."""
    guess = problem.T_world_model_init
    start = guess[:3, :3] @ centroid_body + guess[:3, 3]
    found = np.einsum("kij,j->ki", poses[:, :3, :3], centroid_body) + poses[:, :3, 3]
    return np.linalg.norm(found - start, axis=1) > reach


def surface_terms(model: matching.ModelIndex, poses: np.ndarray, scene_pts_world: np.ndarray, cfg: IcpConfig
                  ) -> np.ndarray:
    """Per-point data terms (K, N), m^2, of poses (K, 4, 4): min(d, score_distance)^2 with d the scene point's
    distance to the posed model's surface (:func:`matching.surface_distances`)."""
    body = _transform(invert_poses(poses), scene_pts_world)
    return np.stack([np.minimum(matching.surface_distances(model, points, cfg.score_distance),
                                cfg.score_distance) ** 2 for points in body])


def prior_kept(per_point: np.ndarray, penalties: np.ndarray, sigmas: float) -> bool:
    """Whether the prior's pose is kept, from the per-point data terms (3, N) (m^2) and upright penalties (3,)
    of the prior's pose, ICP's pose polished with the prior, and ICP's pose as found: when
    :func:`data_choice` picks it over the polished pose and the data do not prefer the pose as found beyond
    ``sigmas`` standard errors (:func:`prior_beats_data`)."""
    return data_choice(per_point[:2], penalties[:2], sigmas) == 0 and not prior_beats_data(per_point[[2, 0]], sigmas)


def data_choice(per_point: np.ndarray, penalties: np.ndarray, sigmas: float) -> int:
    """0 (the prior's pose) or 1 (plain ICP's, polished with the prior) from their per-point data terms (2, N)
    (m^2) and upright penalties (2,). With d_i the per-point difference (ICP's minus the prior's) and SE its
    standard error, the prior's pose is kept only when the objective it shapes, data term plus penalty, is
    lower by more than ``sigmas`` SE (:func:`prior_beats_data`) and the data term alone is not higher by more
    than ``sigmas`` SE; otherwise plain ICP's. Within the data's noise the prior may still win where it is
    informed, a tilt (its penalty grows as 1 - cos tilt), but never on a tie between upright aliases: there it
    knows nothing, and the prior-free search's basin stands."""
    difference = per_point[1] - per_point[0]
    noise = difference.std() / np.sqrt(len(difference))
    data_against = difference.mean() < -sigmas * noise
    return 0 if prior_beats_data(per_point, sigmas, penalties) and not data_against else 1


def prior_beats_data(per_point: np.ndarray, sigmas: float, penalties: np.ndarray | None = None) -> bool:
    """Whether the pose of row 0 of per-point score terms (2, N) (m^2), plus its penalty (``penalties`` (2,),
    none by default), scores lower than that of row 1 by more than ``sigmas`` standard errors of their paired
    per-point difference."""
    difference = per_point[1] - per_point[0]
    noise = difference.std() / np.sqrt(len(difference))
    gap = difference.mean() + (0.0 if penalties is None else float(penalties[1] - penalties[0]))
    return bool(gap > sigmas * noise)


def _search(starts: np.ndarray, problem: Problem, model: matching.ModelIndex, normals_world: np.ndarray | None,
            cfg: IcpConfig, yaw_only: bool, hopping: bool = False) -> _Restarts:
    """The loop from every start (K, 4, 4) at once: annealed Huber scale, losers pruned at ``prune_after``
    (:func:`prune_keep`; ``hopping``: the starts are hops)."""
    restarts = _Restarts.start(starts)
    for iteration in range(cfg.max_iterations):
        active = restarts.active()
        if len(active) == 0:
            break
        _iterate(restarts, active, problem, model, normals_world, cfg, iteration, yaw_only)
        keep = prune_keep(iteration, cfg, hopping)
        if keep is not None:
            restarts.prune(cfg.prune_ratio, keep)
        stop_if_agreed(restarts, model.centroid, cfg, iteration)
    return restarts


def stop_if_agreed(restarts: _Restarts, centroid_body: np.ndarray, cfg: IcpConfig, iteration: int,
                   group: slice = slice(None)) -> None:
    """Drop the restarts of ``group`` still running once ``stop_when_agreed`` of its converged restarts ended
    where its lowest-scoring restart did and every running one scores worse than that by more than
    ``stop_margin`` (never while the Huber scale anneals, nor before ``prune_after``)."""
    if cfg.stop_when_agreed <= 0 or iteration + 1 < max(cfg.prune_after, cfg.huber_anneal_iterations):
        return
    from bim2rdt.registration import kernels  # numba's import waits for the first registration

    start, stop, _ = group.indices(len(restarts.poses))
    kernels.stop_agreed(restarts.poses, restarts.scores, restarts.done, restarts.pruned, start, stop,
                        np.asarray(centroid_body, dtype=float), cfg.stop_when_agreed, cfg.stop_margin)


def prune_keep(iteration: int, cfg: IcpConfig, hopping: bool) -> int | None:
    """How many restarts at most survive the pruning after loop iteration ``iteration`` (0-based), or None when
    none runs then: at ``prune_after``, ``prune_keep`` (``hop_prune_keep`` among hops)."""
    if iteration + 1 == cfg.prune_after:
        return cfg.hop_prune_keep if hopping else cfg.prune_keep
    return None


def _search_together(problems: list[Problem], model: matching.ModelIndex, normals_world: np.ndarray | None,
                     cfg: IcpConfig, starts: list[np.ndarray] | None = None, hopping: bool = False
                     ) -> list[_Restarts]:
    """:func:`_search` of each problem's restarts (:func:`_restart_starts`, not yaw_only), the problems
    differing only in their upright bias, as ONE batch through the loop: each restart steps under its own
    problem's bias, and each problem's restarts are pruned among themselves, when its own search would have
    pruned them (it was still running). Every restart's arithmetic is the same as in its own search (the loop
    is per restart; batching shares the per-call overhead, most of an iteration's time), so each result is
    that search's, and the per-call numpy overhead is paid once for all of them. ``starts``: each problem's
    initial poses (K_i, 4, 4) (hops), instead of its restarts; ``hopping``: they are hops (:func:`prune_keep`)."""
    if starts is None:
        starts = [_restart_starts(problem, model, cfg, False) for problem in problems]
    edges = np.cumsum([0] + [len(s) for s in starts])
    groups = [slice(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]
    bias = np.concatenate([np.full(len(s), problem.upright_bias) for s, problem in zip(starts, problems)])
    restarts = _Restarts.start(np.concatenate(starts))
    for iteration in range(cfg.max_iterations):
        active = restarts.active()
        if len(active) == 0:
            break
        counts = np.diff(np.searchsorted(active, edges))  # each group's active restarts
        running = [g for g, count in zip(groups, counts) if count]
        _iterate(restarts, active, problems[0], model, normals_world, cfg, iteration, False, bias[active])
        keep = prune_keep(iteration, cfg, hopping)
        if keep is not None:
            for group in running:
                restarts.prune(cfg.prune_ratio, keep, group)
        for group in running:
            stop_if_agreed(restarts, model.centroid, cfg, iteration, group)
    return [restarts.part(group) for group in groups]


def hop(best: RegistrationResult, problem: Problem, model: matching.ModelIndex, normals_world: np.ndarray | None,
        cfg: IcpConfig, yaw_only: bool) -> RegistrationResult:
    """Basin hopping around the kept pose, up to ``hop_rounds`` times: the loop again from it turned about the
    world up through the centroid by up to +-2 ``hop_yaw_deg`` and shifted by up to ``hop_shift`` along its own
    x and y axes, and, under an upright prior (not yaw_only), from it levelled (:func:`hop_starts`). The best
    hop replaces the kept pose only when its score is lower by more than ``hop_sigmas`` standard errors of the
    paired per-point difference and by more than ``hop_gain`` of the kept score (:func:`clearly_lowest`): a
    hop must clearly win, or the choice of :func:`pick_restart` stands.
    On a pallet the restarts' spacing (22 degrees) is far wider than the yaw basin between deck boards (~5
    degrees), so every restart can end a few degrees or one board off (S4: the kept pose scored 103-141 where
    the truth scores 66-86, x 1e-6 m^2); hops of 3-6 degrees and 4 cm step across. ``register`` hops only
    when fewer than ``hop_unless_agreeing`` surviving restarts ended where the kept one did, and never with a
    single restart: hops widen the restarts' search, and a caller asking for one start (a local fit from a
    trusted pose, localization's yaw-only camera fix) has said where the basin is."""
    rounds = _hop_rounds(best, problem, model, cfg, yaw_only)
    starts, best = _next_round(rounds, None)
    while starts is not None:
        starts, best = _next_round(rounds, _search(starts, problem, model, normals_world, cfg, yaw_only, True))
    return best


def _next_round(rounds, searched: _Restarts | None):
    """Send a :func:`_hop_rounds` generator its round's searched restarts (None to begin) -> (the next round's
    starts, None), or (None, the kept result) when it has finished."""
    try:
        return rounds.send(searched), None
    except StopIteration as finished:
        return None, finished.value


def _hop_rounds(best: RegistrationResult, problem: Problem, model: matching.ModelIndex, cfg: IcpConfig,
                yaw_only: bool):
    """:func:`hop` as a generator: yields each round's starts (K, 4, 4), is sent their searched restarts
    (:class:`_Restarts`), and returns the kept result; so that two searches' hops can share one loop
    (:func:`_hop_together`)."""
    centroid = model.centroid
    for _ in range(cfg.hop_rounds):
        starts = hop_starts(best.pose, centroid, problem.up_world, cfg,
                            level=problem.upright_bias > 0.0 and not yaw_only)
        hops = yield starts
        alive = np.flatnonzero(~hops.pruned)
        poses = np.concatenate([best.pose[None], hops.poses[alive]])
        scores, pairs = score_poses(model, poses, problem.scene_pts_world, cfg)
        penalties = upright_penalty(poses, pairs, problem, cfg)
        per_point = np.minimum(pairs.residual, cfg.score_distance) ** 2
        winner = clearly_lowest(per_point, penalties, cfg.hop_sigmas, cfg.hop_gain)
        best = replace(best, total_iterations=best.total_iterations + int(hops.iterations.sum()))
        if winner == 0:
            break
        pose = poses[winner]
        best = replace(best, pose=pose.copy(), score=float(scores[winner] + penalties[winner]),
                       iterations=int(hops.iterations[alive[winner - 1]]),
                       converged=bool(hops.done[alive[winner - 1]]),
                       tilt_deg=float(np.rad2deg(tilt_angle(pose[:3, :3], problem.up_world))))
    return best


def _hop_together(kept: list[RegistrationResult], problems: list[Problem], model: matching.ModelIndex,
                  normals_world: np.ndarray | None, cfg: IcpConfig) -> list[RegistrationResult]:
    """:func:`hop` from each kept result under its own problem (not yaw_only), the problems differing only in
    their bias: each round of every search still hopping runs as one batch (:func:`_search_together`), and
    each search goes on or stops by its own rounds. The results are each :func:`hop`'s."""
    rounds = [_hop_rounds(best, problem, model, cfg, False) for best, problem in zip(kept, problems)]
    steps = [_next_round(r, None) for r in rounds]  # (starts or None, result or None) per search
    while any(starts is not None for starts, _ in steps):
        order = [i for i, (starts, _) in enumerate(steps) if starts is not None]
        searched = _search_together([problems[i] for i in order], model, normals_world, cfg,
                                    [steps[i][0] for i in order], hopping=True)
        for i, restarts in zip(order, searched):
            steps[i] = _next_round(rounds[i], restarts)
    return [result for _, result in steps]


def agreeing(restarts: _Restarts, pose: np.ndarray, centroid_body: np.ndarray) -> int:
    """How many surviving restarts ended where ``pose`` is (centroid within 1 cm, rotation within 1 degree)."""
    return int(np.count_nonzero(near(restarts.poses[~restarts.pruned], pose, centroid_body)))


def near(poses: np.ndarray, pose: np.ndarray, centroid_body: np.ndarray, distance: float = 0.01,
         degrees: float = 1.0) -> np.ndarray:
    """(K,) whether each of ``poses`` (K, 4, 4) puts the model's centroid within ``distance`` (m) of where
    ``pose`` puts it and turns it by less than ``degrees`` from ``pose``."""
    shift = np.linalg.norm(np.einsum("kij,j->ki", poses[:, :3, :3] - pose[:3, :3], centroid_body)
                           + poses[:, :3, 3] - pose[:3, 3], axis=1)
    turn = rotation_angle(np.einsum("kij,lj->kil", poses[:, :3, :3], pose[:3, :3]))
    return (shift < distance) & (turn < np.deg2rad(degrees))


def hop_starts(T: np.ndarray, centroid_body: np.ndarray, up_world: np.ndarray, cfg: IcpConfig,
               level: bool = False) -> np.ndarray:
    """The hops from pose ``T`` (24, 4, 4; 25 with ``level``): the 5 x 5 grid of turns by -2..2 x
    ``hop_yaw_deg`` about ``up_world`` through the centroid and shifts by 0, -+``hop_shift`` along the pose's own
    x and y axes, less ``T`` itself; with ``level``, also ``T`` with its tilt removed (about the centroid).
    Turns and shifts together, not one or the other: a pallet left one board and a few degrees off (S4: 5-8
    degrees and 3-5 cm) is in neither's basin alone, and 8 one-way hops left 3 such pallets per 150 where the
    grid finds them. The levelled hop is the upright prior's own candidate: a flat pallet kept 1.2 degrees
    tilted on one edge, 1.2-1.4 cm high, scored 3 standard errors worse than its truth and the grid did not
    level it."""
    yaws = np.deg2rad(cfg.hop_yaw_deg) * np.array([0.0, -2.0, -1.0, 1.0, 2.0])
    turns = np.tile(np.eye(4), (len(yaws), 1, 1))
    turns[:, :3, :3] = axis_angle(np.broadcast_to(up_world, (len(yaws), 3)), yaws)
    centre = T[:3, :3] @ centroid_body + T[:3, 3]
    turns[:, :3, 3] = centre - np.einsum("kij,j->ki", turns[:, :3, :3], centre)
    shifts = cfg.hop_shift * np.array([[0.0, 0.0], [0.0, -1.0], [0.0, 1.0], [1.0, 0.0], [-1.0, 0.0]]) @ T[:3, :2].T
    grid = np.repeat(turns @ T, len(shifts), axis=0)
    grid[:, :3, 3] += np.tile(shifts, (len(yaws), 1))
    hops = grid[1:]  # (0, 0) is T itself
    if level:
        hops = np.concatenate([hops, level_towards_up(T, centroid_body, up_world, 1.0)[None]])
    return hops


def clearly_lowest(per_point: np.ndarray, penalties: np.ndarray, sigmas: float, gain: float) -> int:
    """Index of the candidate (rows of per-point score terms (K, N), m^2, plus penalties (K,)) whose score is
    lowest, and lower than candidate 0's by more than ``sigmas`` standard errors of their paired difference and
    by more than the fraction ``gain`` of it; 0 when none is."""
    totals = per_point.mean(axis=1) + penalties
    lowest = int(np.argmin(totals))
    if lowest == 0:
        return 0
    noise = (per_point[lowest] - per_point[0]).std() / np.sqrt(per_point.shape[1])
    drop = totals[0] - totals[lowest]
    return lowest if drop > sigmas * noise and drop > gain * totals[0] else 0


def _with_fit(result: RegistrationResult, problem: Problem, model: matching.ModelIndex, cfg: IcpConfig,
              yaw_only: bool) -> RegistrationResult:
    """The result with its fit on the model surface and its pose uncertainty (the prior counts unless the data
    overruled it; yaw_only holds roll and pitch exactly)."""
    prior = 0.0 if result.released else problem.upright_bias
    report = report_fit(result.pose, problem, model, cfg, prior, yaw_only)
    return replace(result, rmse=report.rmse, fitness=report.fitness, uncertainty=report.uncertainty)


def level_towards_up(T: np.ndarray, centroid_body: np.ndarray, up_world: np.ndarray, fraction: float) -> np.ndarray:
    """``T`` with ``fraction`` of its tilt removed, turning about a horizontal axis through the model's centroid.
    The paper words the bias as the fraction of tilt corrected per iteration; applied once to the START, it
    spends the prior where it helps most (a far-off tilt narrows ICP's basin) without compounding: the loop's
    equilibrium still lets a truly tilted object stay tilted."""
    body_up = T[:3, 2]
    axis = np.cross(body_up, up_world)
    if fraction <= 0.0 or np.linalg.norm(axis) < 1e-12:
        return T
    angle = fraction * np.arctan2(np.linalg.norm(axis), body_up @ up_world)
    turn = axis_angle(axis / np.linalg.norm(axis), np.array(angle))
    centre = T[:3, :3] @ centroid_body + T[:3, 3]
    out = T.copy()
    out[:3, :3] = turn @ T[:3, :3]
    out[:3, 3] = centre + turn @ (T[:3, 3] - centre)
    return out


def yaw_restarts(T_init: np.ndarray, centroid_body: np.ndarray, up_world: np.ndarray, cfg: IcpConfig) -> np.ndarray:
    """Initial poses (K, 4, 4): ``T_init`` turned about the world up, through the model's centroid, by evenly
    spaced yaws plus seeded jitter (restart 0 is ``T_init`` itself). A gravity prior cannot fix yaw; restarts can.
    Public so that peers in a benchmark can be given exactly the same starts."""
    k = cfg.restarts
    yaws = restart_yaws(k, cfg.yaw_jitter_deg, cfg.seed)
    T0 = T_init
    centre = T0[:3, :3] @ centroid_body + T0[:3, 3]
    turns = np.tile(np.eye(4), (k, 1, 1))
    turns[:, :3, :3] = axis_angle(np.broadcast_to(up_world, (k, 3)), yaws)
    turns[:, :3, 3] = centre - np.einsum("kij,j->ki", turns[:, :3, :3], centre)
    return turns @ T0


@functools.lru_cache(maxsize=64)
def restart_yaws(restarts: int, jitter_deg: float, seed: int) -> np.ndarray:
    """The restarts' yaws (K,), rad: evenly spaced over a turn, each but the first jittered by a seeded uniform
    draw within +-``jitter_deg``. The same for every registration of one config, so drawn once (a generator's
    construction cost ~50 us, twice a registration); read-only."""
    rng = np.random.default_rng(seed)
    jitter = np.deg2rad(rng.uniform(-jitter_deg, jitter_deg, restarts))
    yaws = 2 * np.pi * np.arange(restarts) / restarts + np.where(np.arange(restarts) == 0, 0.0, jitter)
    yaws.flags.writeable = False
    return yaws


def _iterate(restarts: _Restarts, active: np.ndarray, problem: Problem, model: matching.ModelIndex,
             normals_world: np.ndarray | None, cfg: IcpConfig, iteration: int, yaw_only: bool,
             bias: np.ndarray | None = None) -> None:
    """One pass of Algorithm 1's inner loop for the active restarts: match, relax, trim, weigh, solve (with the
    gravity correspondence and optional yaw-only projection), apply, test convergence. ``bias`` (k,): each
    active restart's upright bias, when they differ (else ``problem``'s)."""
    delta = matching.annealed_delta(iteration, cfg.max_pair_distance, cfg.huber_delta, cfg.huber_anneal_iterations)
    T = restarts.poses[active]
    annealing = delta > cfg.huber_delta
    stride = max(1, cfg.coarse_stride) if annealing else 1  # coarse-to-fine: the wide-scale steps need few points
    bias = problem.upright_bias if bias is None else bias
    if cfg.method == "point_to_plane":
        warm = None  # gated (the localizer's: one restart on a fresh model each frame): no near lists to build
        if normals_world is None:
            if restarts.nearest is None:
                restarts.nearest = np.full((len(restarts.poses), len(problem.scene_pts_world)), -1, np.int64)
            warm = (restarts.nearest, active)
        step = _compiled_step(T, problem, model, cfg, delta, stride, bias, yaw_only, warm, normals_world)
        if step is not None:
            _advance(restarts, active, *step, cfg, annealing)
            return
    scene_body, pairs, w = _weighted_pairs(invert_poses(T), problem, model, normals_world, cfg, delta, stride)
    dst, normals = pairs.samples, pairs.normals  # the model's samples: problem.model_*_body, indexed
    up_body = np.einsum("kji,j->ki", T[:, :3, :3], problem.up_world)
    lam = gravity_weight(dst, w, bias * cfg.gravity_gamma0)
    if problem.support_height is not None:
        scene_body, dst, normals, w = _with_contact_pair(T, up_body, problem, model.extreme_points, cfg.support_weight,
                                                         (scene_body, dst, normals, w))
    dR, dt = SOLVERS[cfg.method].step(scene_body, dst, normals, w, up_body, UP_BODY, lam, yaw_only)
    _advance(restarts, active, dR, dt, matching.truncated_score(pairs, cfg.score_distance), cfg, annealing)


def _compiled_step(T: np.ndarray, problem: Problem, model: matching.ModelIndex, cfg: IcpConfig, delta: float,
                   stride: int, bias: float | np.ndarray, yaw_only: bool, warm: tuple | None = None,
                   normals_world: np.ndarray | None = None):
    """:func:`_iterate`'s match, trim, weigh and point-to-plane solve by the compiled kernels
    (:mod:`bim2rdt.registration.kernels`: the same arithmetic in one pass, ~40 numpy calls fewer) -> (dR, dt,
    scores), or None when a restart has fewer than ``min_pairs`` pairs (RelaxIfFew: the numpy path then runs).
    ``normals_world``: the scene's normals when the normal gate is on (:func:`kernels.gated_residuals`: the
    localizer's fix, decision 0050). ``warm``: the restarts' last nearest samples (K, N) and which of them
    ``T`` are (k,), to start the search from (:func:`matching.nearest_samples`)."""
    from bim2rdt.registration import kernels  # numba's import (~0.5 s) waits for the first registration
    scene_body = kernels.body_points(T, problem.scene_pts_world, stride)
    k, n, _ = scene_body.shape
    distance, index = matching.nearest_samples(model, scene_body, _pair_distance(model, cfg, delta), stride, warm)
    residual, pairs, scores = kernels.pair_residuals(scene_body, distance, index, model.points, model.normals,
                                                     model.spacing, cfg.score_distance)
    if normals_world is not None:
        residual, pairs = kernels.gated_residuals(residual, index, T, normals_world, stride, model.normals,
                                                  float(np.cos(np.deg2rad(cfg.normal_gate_deg))))
    if pairs.min() < cfg.min_pairs:
        return None
    bias_gamma = np.full(k, bias * cfg.gravity_gamma0) if np.ndim(bias) == 0 else bias * cfg.gravity_gamma0
    support = np.nan if problem.support_height is None else problem.support_height
    hull = _NO_HULL if problem.support_height is None else model.extreme_points  # read only on a support
    dR, dt = kernels.plane_steps(T, scene_body, residual, index, model.points, model.normals, hull,
                                 cfg.trim_fraction, cfg.min_pairs, cfg.trim_floor_per_delta * delta, delta, bias_gamma,
                                 problem.up_world, UP_BODY, support, cfg.support_weight, DEGENERATE_RATIO, yaw_only)
    return dR, dt, scores


_NO_HULL = np.zeros((0, 3))
"""The hull points :func:`_compiled_step` hands the kernel off a support (it reads them only on one)."""


def _contact(T: np.ndarray, up_body: np.ndarray, problem: Problem, hull: np.ndarray):
    """Each restart's lowest model point along the world up (k, 3) and it dropped onto the slab (k, 3), body
    frame (see :func:`_with_contact_pair`)."""
    contact = hull[np.argmin(hull @ up_body.T, axis=0)]  # (k, 3) body
    slab_in_body = problem.support_height - T[:, :3, 3] @ problem.up_world
    gap = np.einsum("ki,ki->k", up_body, contact) - slab_in_body
    return contact, contact - gap[:, None] * up_body


def _with_contact_pair(T: np.ndarray, up_body: np.ndarray, problem: Problem, hull: np.ndarray,
                       support_weight: float, pairs: tuple):
    """Append the contact correspondence to the (scene, model, normal, weight) pair arrays: each restart's lowest
    model point along the world up should touch the slab. Its scene partner is that point dropped onto the slab
    plane and its normal the slab's, so the step sees one point-to-plane residual, the gap between the object
    and its support (a tilted object touches with its lowest edge, so a leaning cone still rests on the slab).
    Its weight is ``support_weight`` x the data's total weight, the same meaning for 40 points or 400.
    ``hull`` are the model samples that can be lowest (its convex hull's points)."""
    scene_body, dst, normals, w = pairs
    contact, on_slab = _contact(T, up_body, problem, hull)
    weight = support_weight * w.sum(axis=1)
    return (np.concatenate([scene_body, on_slab[:, None]], axis=1), np.concatenate([dst, contact[:, None]], axis=1),
            np.concatenate([normals, up_body[:, None]], axis=1), np.concatenate([w, weight[:, None]], axis=1))


def _weighted_pairs(T_body_world: np.ndarray, problem: Problem, model: matching.ModelIndex,
                    normals_world: np.ndarray | None, cfg: IcpConfig, delta: float, stride: int):
    """MatchPairs, the normal gate, RelaxIfFew, TrimPairs and RobustWeights at Huber scale ``delta`` (m) for
    every ``stride``-th scene point -> (scene points in each body frame (k, N, 3), pairs, weights (k, N))."""
    scene_body = _transform(T_body_world, problem.scene_pts_world[::stride])
    pairs = matching.match_pairs(model, scene_body, _pair_distance(model, cfg, delta))
    if normals_world is not None:
        normals_body = normals_world[::stride] @ np.swapaxes(T_body_world[:, :3, :3], 1, 2)
        matching.gate_normals(pairs, normals_body, problem.model_normals_body, cfg.normal_gate_deg)
    matching.relax_if_few(pairs, model, scene_body, cfg.min_pairs, cfg.max_pair_distance)
    residual = SOLVERS[cfg.method].residual(pairs, model.spacing)
    matching.trim_pairs(pairs, residual, cfg.trim_fraction, cfg.min_pairs, cfg.trim_floor_per_delta * delta)
    return scene_body, pairs, matching.huber_weights(pairs, residual, delta)


def _pair_distance(model: matching.ModelIndex, cfg: IcpConfig, delta: float) -> float:
    """The k-d tree's bound (m) at Huber scale ``delta`` (m): ``pair_distance_per_delta`` x delta, at least
    ``score_distance``, plus a sample spacing, at most ``max_pair_distance``."""
    return min(cfg.max_pair_distance, max(cfg.pair_distance_per_delta * delta, cfg.score_distance) + model.spacing)


def _advance(restarts: _Restarts, active: np.ndarray, dR: np.ndarray, dt: np.ndarray, scores: np.ndarray,
             cfg: IcpConfig, annealing: bool) -> None:
    """Apply the body-frame steps (T_new = T inv(step)), record the scores, and mark restarts done whose step
    was small or whose score settled (never while the Huber scale is still annealing)."""
    from bim2rdt.registration import kernels  # numba's import waits for the first registration

    kernels.settle_steps(restarts.poses, restarts.iterations, restarts.scores, restarts.done, active, dR, dt,
                         np.asarray(scores, dtype=float), cfg.convergence_rot_rad, cfg.convergence_trans,
                         cfg.convergence_score_rel, annealing)


def _transform(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply poses (k, 4, 4) to points (N, 3) -> (k, N, 3)."""
    return points @ np.swapaxes(T[:, :3, :3], 1, 2) + T[:, None, :3, 3]


def score_poses(model: matching.ModelIndex, poses: np.ndarray, scene_pts_world: np.ndarray, cfg: IcpConfig,
                warm: tuple | None = None):
    """Truncated surface-residual score of candidate poses (K, 4, 4) -> (scores (K,), pairs). Lower is better.
    Points farther than ``score_distance`` + a sample spacing from every sample have a residual beyond the
    truncation (it is at least the distance less the spacing), so the search stops there (+1 um against
    round-off): their residuals are inf, not some value past the truncation, and every truncated use is the same.
    ``warm``: the poses' restarts' last nearest samples, as :func:`matching.nearest_samples` takes them (the same
    answers, fewer tree queries)."""
    bound = min(cfg.max_pair_distance, cfg.score_distance + model.spacing + 1e-6)
    pairs = matching.scored_residuals(model, _transform(invert_poses(poses), scene_pts_world), bound, warm)
    return matching.truncated_score(pairs, cfg.score_distance), pairs


def upright_penalty(poses: np.ndarray, pairs: matching.Residuals, problem: Problem, cfg: IcpConfig) -> np.ndarray:
    """The gravity term of the loop's cost, per scene point, in the score's units (m^2), so restarts are compared
    on the objective the loop minimises: lambda |R g_m - g_w|^2 / N with lambda = beta gamma0 sum |p~|^2 over the
    pose's inlier pairs (as in the loop, not over the whole model: a thin tripod seen among ground points has
    few inliers, and charging the whole model's spread would let a small tilt outweigh the data), and
    |R g_m - g_w|^2 = 2 (1 - cos tilt). Zero for plain ICP; decisive against an upside-down tripod."""
    if problem.upright_bias == 0.0:
        return np.zeros(len(poses))
    inliers = (pairs.residual < cfg.score_distance).astype(float)
    dst = np.take(problem.model_pts_body, pairs.model_index, axis=0)
    lam = gravity_weight(dst, inliers, problem.upright_bias * cfg.gravity_gamma0)
    cos_tilt = np.cos(tilt_angle(poses[:, :3, :3], problem.up_world))
    return lam * 2.0 * (1.0 - cos_tilt) / pairs.residual.shape[1]


def _release_if_leaning(best: RegistrationResult, problem: Problem, model: matching.ModelIndex,
                        normals_world: np.ndarray | None, cfg: IcpConfig) -> RegistrationResult:
    """Test the upright prior against the data, and drop it when the data clearly show a lean.

    The best pose is polished without the prior (one restart, final Huber scale); the polished pose wins when
    the posterior odds of 'leaning' beat those of 'upright as the prior pulled it': the data's evidence, a BIC
    Bayes factor log B = dSSR / (2 sigma^2) - log N for the two tilt parameters the prior had held (sigma^2
    from the polished fit's inlier residuals), must exceed the prior odds log(beta / (1 - beta)) of the
    family's upright bias beta read as the probability of standing upright. A cone truly leaning 12 degrees
    pays that easily (its residuals drop many-fold); a spurious tilt fitted to noise or clutter on an
    ambiguous view does not, so the prior keeps it upright. Without this, a soft prior costs every truly
    leaning object a fraction of its lean (1.5-2 degrees on the benchmark's knocked cones and tripods)."""
    polished = _polish_without_prior(best.pose, problem, model, normals_world, cfg)
    _, pairs = score_poses(model, np.stack([best.pose, polished.poses[0]]), problem.scene_pts_world, cfg)
    if lean_evidence(pairs.residual, cfg.score_distance) <= np.log(problem.upright_bias / (1 - problem.upright_bias)):
        return best
    pose = polished.poses[0]
    return replace(best, pose=pose.copy(), released=True,
                   tilt_deg=float(np.rad2deg(tilt_angle(pose[:3, :3], problem.up_world))),
                   total_iterations=best.total_iterations + int(polished.iterations[0]))


def _polish_without_prior(pose: np.ndarray, problem: Problem, model: matching.ModelIndex,
                          normals_world: np.ndarray | None, cfg: IcpConfig) -> _Restarts:
    """``release_iterations`` of the loop from ``pose`` with the bias off, at the final Huber scale."""
    return _polish(pose, replace(problem, upright_bias=0.0), model, normals_world, cfg, cfg.release_iterations)


def _polish(pose: np.ndarray, problem: Problem, model: matching.ModelIndex, normals_world: np.ndarray | None,
            cfg: IcpConfig, iterations: int | None = None) -> _Restarts:
    """``iterations`` (default ``polish_iterations``) of the loop from ``pose`` under ``problem`` (its bias), at
    the final Huber scale."""
    restarts = _Restarts.start(pose[None].copy())
    first = cfg.huber_anneal_iterations  # past the annealing: this is a polish, not a search
    for iteration in range(first, first + (cfg.polish_iterations if iterations is None else iterations)):
        active = restarts.active()
        if len(active) == 0:
            break
        _iterate(restarts, active, problem, model, normals_world, cfg, iteration, False)
    return restarts


def lean_evidence(residuals: np.ndarray, truncation: float, freed: int = 2) -> float:
    """log Bayes factor (BIC) of the freed pose over the held one, from their surface residuals (2, N), m:
    dSSR / (2 sigma^2) - (freed / 2) log n over truncated residuals, sigma^2 from the freed fit's n inliers.
    -inf when too few inliers to judge."""
    held, freed_sq = np.minimum(residuals, truncation) ** 2
    inliers = residuals[1] < truncation
    n = int(inliers.sum())
    if n <= 6:
        return -np.inf
    sigma2 = max(float(freed_sq[inliers].sum()) / (n - 6), 1e-12)
    return float(held.sum() - freed_sq.sum()) / (2.0 * sigma2) - 0.5 * freed * np.log(n)


def _keep_best(restarts: _Restarts, problem: Problem, model: matching.ModelIndex, cfg: IcpConfig
               ) -> RegistrationResult:
    """Algorithm 1's ScoreAndKeepBest: rescore every surviving restart at its final pose and keep one by
    :func:`pick_restart` (the data decide, the upright penalty only breaks their ties)."""
    alive = np.flatnonzero(~restarts.pruned)
    poses = restarts.poses[alive]
    warm = None if restarts.nearest is None else (restarts.nearest, alive)
    scores, pairs = score_poses(model, poses, problem.scene_pts_world, cfg, warm)
    penalties = upright_penalty(poses, pairs, problem, cfg)
    per_point = np.minimum(pairs.residual, cfg.score_distance) ** 2
    best = pick_restart(per_point, penalties, poses, problem, cfg, model.centroid)
    pose = poses[best]
    return RegistrationResult(
        pose=pose.copy(), rmse=float("nan"), fitness=float("nan"),  # reported on the final pose by _with_fit
        iterations=int(restarts.iterations[alive[best]]),
        score=float(scores[best] + penalties[best]),
        restart=int(alive[best]),
        converged=bool(restarts.done[alive[best]]),
        tilt_deg=float(np.rad2deg(tilt_angle(pose[:3, :3], problem.up_world))),
        total_iterations=int(restarts.iterations.sum()),
        restart_scores=tuple(float(s) for s in scores + penalties),
    )


def pick_restart(per_point: np.ndarray, penalties: np.ndarray, poses: np.ndarray, problem: Problem,
                 cfg: IcpConfig, centroid_body: np.ndarray | None = None) -> int:
    """Index of the restart to keep, from each restart's per-point score terms (K, N) (m^2), its upright
    penalty (K,) and its pose (K, 4, 4); ``centroid_body`` is the model samples' centroid (computed when not
    given).

    The lowest score wins, unless it wins only within the score's own noise. On a sparse, half-occluded view
    many restarts end in distinct poses that explain the points about equally well (a box slid along its
    hidden side, turned by 90 degrees); the lowest of many near-ties is then a lottery that favours the
    extreme ones. That is how the upright prior can cost accuracy: levelled starts let far more
    restarts reach such upright near-ties than plain ICP's tilted starts (which mostly die at pruning and
    leave the one nearest the start), so SG-ICP drew from a larger lottery. Here a restart ties with the
    lowest when its score is behind by at most ``tie_sigmas`` standard errors of the paired per-point
    difference, and among ties the one with the least of (standard errors behind + its centroid's distance
    from the initial guess's / ``tie_distance``) is kept: when the view cannot tell, stay near where the guess
    put the object (the BIM or last pose), and let the score decide between poses the same distance away
    (symmetric copies of a cone). A soft trade, not the nearest outright: with a guess 10-15 cm off (S1), a tie
    1.9 standard errors behind but 4 cm nearer the guess is a slide, and must not win over the truth."""
    totals = per_point.mean(axis=1) + penalties
    lowest = int(np.argmin(totals))
    if cfg.tie_sigmas <= 0.0 or len(totals) == 1:
        return lowest
    difference = per_point - per_point[lowest]
    noise = np.maximum(difference.std(axis=1) / np.sqrt(per_point.shape[1]), 1e-300)
    behind = (totals - totals[lowest]) / noise  # how many standard errors each restart's score is behind
    centroid = problem.model_pts_body.mean(axis=0) if centroid_body is None else centroid_body
    start = problem.T_world_model_init[:3, :3] @ centroid + problem.T_world_model_init[:3, 3]
    moved = np.linalg.norm(np.einsum("kij,j->ki", poses[:, :3, :3], centroid) + poses[:, :3, 3] - start, axis=1)
    tied = np.flatnonzero(behind <= cfg.tie_sigmas)
    return int(tied[np.argmin(behind[tied] + moved[tied] / cfg.tie_distance)])
