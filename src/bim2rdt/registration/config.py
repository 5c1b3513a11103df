"""The knobs of Algorithm 1 (SG-ICP), one validated object; plain ICP is the same loop with ``upright_bias=0``.

Distances are metres, angles degrees unless a name says radians. Defaults suit site objects of 0.3-3 m seen by
an RGB-D camera at 1-4 m (depth noise of a few millimetres, sparse corner points, clutter in the ROI).
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field


class IcpConfig(BaseModel):
    """Parameters of the registration loop (the paper's Algorithm 1 inputs)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    restarts: int = Field(
        16, ge=1, le=64,
        description="Yaw restarts about gravity, evenly spaced over 360 degrees. A pallet's yaw basin is under 5 "
                    "degrees wide (its deck boards alias: a start 10 degrees off ends 9-16 degrees off, even after "
                    "200 iterations), so restarts, not iterations, find it. 16 restarts pruned at iteration 4 cost "
                    "about what 8 pruned at iteration 8 did and cut S4 RMSE ~30 % for ICP and SG-ICP (20-trial "
                    "probe). See prune_keep for a setting that helps SG-ICP more but not ICP.")
    yaw_jitter_deg: float = Field(10.0, ge=0.0, le=180.0, description="Uniform jitter added to each restart's yaw.")
    sample_count: int = Field(
        10000, ge=6,
        description="Model surface samples (points with normals) per object. 10,000, not 2,000: Shi-Tomasi corners sit on "
                    "edges, where the nearest of sparse samples often lies on the neighbouring face; from the true "
                    "pose a pallet then slid 1.4 cm and turned 1.3 degrees (median), at 10,000 it stays within 2 mm "
                    "and 0.2 degrees, and S1-S4 ICP RMSE fell 10-40 %. The k-d tree query grows only with log M.")
    max_iterations: int = Field(30, ge=1, le=1000, description="Iteration cap per restart.")
    max_pair_distance: float = Field(
        0.25, gt=0.0,
        description="Pairs farther apart than this are not matched, m: the loop presumes the initial guess within "
                    "this distance of the object. So, under a prior, where the data tie between the prior's result "
                    "and plain ICP's, a result whose centroid ended farther than this from the guess's loses to one "
                    "within it (registration.icp.guess_decides).")
    pair_distance_per_delta: float = Field(
        4.0, gt=0.0,
        description="The pair distance shrinks with the annealed Huber scale to this multiple of it (never below "
                    "score_distance), plus the model's sample spacing: pairs that far off the surface would get a "
                    "Huber weight < 1/4 anyway, and a tighter k-d tree bound makes the query (85-90 % of an "
                    "iteration) cheaper.")
    normal_gate_deg: float = Field(
        90.0, gt=0.0, le=90.0,
        description="Reject a pair whose model normal and local scene normal (PCA, unsigned) differ by more; 90 = off. "
                    "Off by default: PCA normals of sparse corner points (on edges, mixed with clutter) are too noisy; "
                    "in the S1-S4 scenarios a 60-75 degree gate cost more right pairs than it removed wrong ones.")
    min_pairs: int = Field(6, ge=6, description="RelaxIfFew: below this many pairs the gates are dropped.")
    trim_fraction: float = Field(0.1, ge=0.0, lt=0.9, description="Fraction of the farthest pairs dropped each step.")
    trim_floor_per_delta: float = Field(
        1.0, ge=0.0, description="Trimming never drops a pair within this multiple of the current Huber scale.")
    huber_delta: float = Field(0.01, gt=0.0, description="Final Huber scale, m (about 2-3x the depth noise).")
    huber_anneal_iterations: int = Field(
        6, ge=0, description="Iterations over which the Huber scale shrinks geometrically from max_pair_distance.")
    coarse_stride: int = Field(
        2, ge=1, description="While the Huber scale is still annealing, use every n-th scene point (coarse-to-fine).")
    convergence_rot_rad: float = Field(1e-3, gt=0.0, description="Converged when the step rotates less, rad ...")
    convergence_trans: float = Field(1e-3, gt=0.0, description="... and translates less, m (10x below the 1 cm "
                                                                 "success bar; IRLS steps shrink geometrically).")
    convergence_score_rel: float = Field(
        1e-3, ge=0.0, description="... or when the restart's score changed by less than this fraction (the pairs "
                                  "have settled; Open3D's relative-fitness test).")
    gravity_gamma0: float = Field(
        0.05, ge=0.0,
        description="Global gravity weight; lambda = upright_bias * gamma0 * sum(w |p - p_mean|^2) (scale-free). "
                    "0.05 keeps the prior a soft tie-breaker: it levels what the data leave unconstrained and "
                    "ranks restarts, but a cone (bias 0.45) truly leaning 8-20 degrees keeps its lean to ~1.5 "
                    "degrees; at the former 0.2 the same cones were pulled 6-14 degrees towards upright.")
    start_leveling: float = Field(
        1.0, ge=0.0, le=1.0,
        description="Before the loop, remove upright_bias x this fraction of the initial tilt (0 = start as given).")
    support_weight: float = Field(
        1.0, ge=0.0,
        description="Weight of the contact correspondence (the lowest model point onto the slab, when register is "
                    "given a support_height) as a fraction of the data's total weight. A drum seen from 1 m up "
                    "shows its rim in 5-17 corners, too few to pin its height (it floated 1.5-2 cm in S1); "
                    "at 1.0 the slab pins it without outvoting a clear view.")
    release_iterations: int = Field(
        10, ge=0, le=1000,
        description="Iterations of the prior-free polish that tests whether the data show a lean strongly enough "
                    "to overrule the upright prior (a BIC Bayes factor against the bias as prior odds); 0 = off.")
    method: Literal["point_to_point", "point_to_plane"] = Field(
        "point_to_plane", description="Rigid solve: closed-form weighted Kabsch, or Gauss-Newton on model normals.")
    score_distance: float = Field(0.03, gt=0.0, description="Truncation of the restart score and inlier radius, m.")
    prune_after: int = Field(
        4, ge=1, description="Iteration at which losing restarts are dropped: early, so many restarts cost little.")
    prune_keep: int = Field(
        64, ge=1,
        description="At prune_after, keep at most this many restarts (the best); 64 = no cap. Measured (50 trials): "
                    "restarts=48, prune_after=3, prune_keep=6 cost ~4 ms more per object and cut SG-ICP's S4 RMSE "
                    "from 0.0072 to 0.0062 m, but made plain ICP worse in S1 and S3 (0.0057 -> 0.0066, 0.0068 -> "
                    "0.0090 m): early scores are telling only for restarts an upright prior has levelled. Not the "
                    "default, so the benchmark's ICP baseline runs at a setting that suits it too.")
    prune_ratio: float = Field(1.5, ge=1.0, description="Drop restarts whose score is worse than ratio x the best.")
    hop_prune_keep: int = Field(
        64, ge=1,
        description="prune_keep for the hops' searches (registration.icp.hop): hops start within a few degrees "
                    "and centimetres of each other, so prune_ratio alone keeps ~92 % of them. Measured (10 trials, "
                    "seed 0): 12 (with a re-prune at iteration 8, which alone saved 2 %) cut the restart-iterations "
                    "of S1-S4, F1, F7, F8, F10 and F11 by 17 % (hops are ~40 % of "
                    "the work, but the median registration does not hop) with S4 success and the alias targets "
                    "held, 6 cut 25 % but S4 fell to 83 %. 64 = no cap (the default until a 50-trial S4 check).")
    stop_when_agreed: int = Field(
        2, ge=0,
        description="Stop a search once this many of its restarts have converged where its lowest-scoring restart "
                    "did (within 1 cm and 1 degree) and every restart still running scores worse than that one by "
                    "more than stop_margin: the running ones are dropped as losing. Such a pose needs no hop "
                    "either (hop_unless_agreeing). At 2 the restart-iterations of S1-S4 fell 17 %, 1-2 of 60 "
                    "poses moved by at most 1.2 mm; at 1 (the lowest converged alone) 5 of 60 moved (decision "
                    "0035). 0 = off.")
    stop_margin: float = Field(
        1.0, ge=1.0, description="A running restart is dropped by stop_when_agreed only when its score exceeds "
                                 "this multiple of the agreed restart's.")
    tie_sigmas: float = Field(
        2.0, ge=0.0,
        description="A restart ties with the lowest-scoring one when its score is behind by at most this many "
                    "standard errors of the paired per-point difference; among ties the one nearest the initial "
                    "guess (see tie_distance, registration.icp.pick_restart) is kept. 0 = always the lowest score. "
                    "Without it the lowest of many upright near-ties wins by clutter luck on sparse views.")
    prior_free_pass: bool = Field(
        True,
        description="Under an upright prior, also run plain ICP's search (the unlevelled starts, no prior) in the "
                    "same batch, and keep ICP's result (polished with the prior) unless the prior's objective "
                    "beats it beyond the data's noise (registration.icp.keep_data_choice): the prior then cannot "
                    "leave SG-ICP in a worse yaw or slide alias than ICP. False = the prior's search only.")
    polish_iterations: int = Field(
        10, ge=0, le=1000,
        description="Iterations of the loop with the prior, at the final Huber scale, from the prior-free pass's "
                    "pose before the choice (prior_free_pass): the prior levels it within its basin, and it is "
                    "judged and kept as levelled.")
    tie_distance: float = Field(
        0.03, gt=0.0,
        description="Among tied restarts, a centroid this much farther (m) from the initial guess's weighs as "
                    "much as a score one standard error behind. 3 cm: at 2 cm SG-ICP's S1 RMSE rose from 3.4 to "
                    "3.7 mm (slides nearer a guess 10-15 cm off won), at 5 cm F1's gain vanished (50 trials).")
    unobservable_ratio: float = Field(
        0.01, gt=0.0, lt=1.0,
        description="A pose direction is reported unobservable when its information (rotations scaled by the "
                    "view's size, so both are in metres) is below this fraction of the best-constrained "
                    "direction's (see registration.uncertainty.weak_directions).")
    hop_rounds: int = Field(
        3, ge=0, le=20,
        description="Rounds of basin hopping after the restarts (registration.icp.hop): the loop again from the "
                    "kept pose turned by 0, +-1 and +-2 hop_yaw_deg and shifted by 0 or hop_shift along its own x "
                    "or y axis (the 5 x 5 grid less the pose itself) and, under an upright prior, levelled; a hop "
                    "replaces the kept pose only when it scores clearly lower (hop_sigmas, hop_gain). A pallet's "
                    "yaw basin (boards 10 cm apart) is ~5 degrees, narrower than any affordable restart spacing: "
                    "S4's SG-ICP success 69 -> 89 % (50 trials). Never with restarts=1 (a local fit). 0 = off.")
    hop_sigmas: float = Field(
        1.0, ge=0.0, description="A hop must score lower than the kept pose by more than this many standard errors "
                                 "of the paired per-point difference (at 2, S4's pallet stayed at 65 %) ...")
    hop_gain: float = Field(0.02, ge=0.0, lt=1.0,
                            description="... and by more than this fraction of the kept score (a hop back into the "
                                        "same basin differs by less, with a tiny standard error).")
    hop_unless_agreeing: int = Field(
        2, ge=0, description="Hop only when fewer surviving restarts than this ended where the kept one did "
                             "(within 1 cm and 1 degree): a pose several restarts agree on needs no hop (30-40 % of "
                             "S1-S4's registrations hop). 0 = never hop.")
    hop_yaw_deg: float = Field(3.0, gt=0.0, le=45.0, description="The smaller yaw of a hop, deg.")
    hop_shift: float = Field(0.04, gt=0.0, description="Shift of a hop along the kept pose's x and y axes, m.")
    scene_normal_neighbours: int = Field(16, ge=3, description="Neighbours for the scene points' PCA normals.")
    seed: int = Field(0, description="Seed of the yaw jitter, so runs are reproducible.")
