"""The knobs of the global search (:func:`bim2rdt.localization.find_pose`): lengths in metres, angles in degrees."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from bim2rdt.localization.config import LocalizationConfig


class OdometryCalibrationConfig(BaseModel):
    """Online calibration of a sweep's odometry against its own confident fixes
    (:mod:`bim2rdt.localization.calibration`), and when a direction a view leaves free (along a bare wall) is
    taken from the calibrated odometry: lengths in metres."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    min_legs: int = Field(
        6, ge=3, description="The calibration is fitted and validated only over at least this many legs between "
                             "two consecutive frames fixed in every direction: fewer, and the raw odometry is used.")
    max_legs: int = Field(60, ge=3, description="Only the latest this many legs are fitted (a bias may change).")
    min_leg: float = Field(
        0.5, gt=0.0, description="A leg shorter than this (m) is not fitted: a turn in place says nothing of the "
                                 "bias per metre walked.")
    outlier_sigmas: float = Field(
        3.0, gt=0.0, description="A leg whose error per metre is this many robust deviations (1.4826 MAD) off "
                                 "the fit is left out of it (a slip, a wrong fix); it still counts in the "
                                 "validation residuals.")
    sigmas: float = Field(
        3.0, gt=0.0, description="A direction the view leaves free is taken from the calibrated odometry only when "
                                 "this many of its standard deviations along it (from the leave-one-out "
                                 "residuals, scaled by the leg's length) are within free_tolerance ...")
    free_tolerance: float = Field(
        0.05, gt=0.0, description="... m: the accuracy a taken pose must have (the bench's 5 cm); otherwise the "
                                  "frame is refused, as without calibration.")
    min_sigma: float = Field(
        0.005, gt=0.0, description="The odometry's predicted position is never trusted below this standard "
                                   "deviation per direction, m (a few legs' residuals may be small by chance).")


class GlobalSearchConfig(BaseModel):
    """Parameters of :func:`bim2rdt.localization.find_pose`: the coarse 2-D search and the refinement's fix."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    fix: LocalizationConfig = Field(default_factory=LocalizationConfig,
                                    description="The 4-DoF fix that refines each candidate (its basin and tests).")
    resolution: float = Field(
        0.1, gt=0.0, le=1.0,
        description="Cell of the coarse search's plan grid, m: the 4-DoF fix's basin (0.6 m) is six cells wide.")
    yaw_step_deg: float = Field(
        3.0, gt=0.0, le=30.0, description="Heading step of the coarse search, deg (the fix's yaw basin is 6 deg).")
    band: tuple[float, float] = Field(
        (0.25, 2.1),
        description="Heights above the floor (m) whose wall-facing points and BIM surfaces the coarse search "
                    "compares: walls and columns, above skirting clutter and below ceiling fittings.")
    sigma: float = Field(0.1, gt=0.0, description="Width of the coarse score's surface likelihood, m.")
    through_weight: float = Field(
        0.6, ge=0.0,
        description="Weight of the occlusion penalty: each 10 cm of a sensor ray inside a wall before its return "
                    "costs this much of a point on a surface (a 15 cm partition about one point).")
    clearance: float = Field(0.15, ge=0.0, description="The sensor stands at least this far from a wall, m.")
    wall_normal_z: float = Field(
        0.35, gt=0.0, le=1.0, description="A point whose normal's vertical part is below this faces sideways "
                                          "(a wall, a column): it takes part in the coarse search.")
    max_plan_points: int = Field(500, ge=20, description="At most this many plan points (an even draw) per search.")
    judge_points: int = Field(
        1000, ge=50, description="Refined candidates are scored on at most this many of the cloud's points (an "
                                  "even draw): on the first surface their ray meets, seen through it, or short of it.")
    quick_points: int = Field(
        1500, ge=100, description="Every coarse peak is first fixed with at most this many of the cloud's points ...")
    quick_ray_deg: float = Field(1.0, gt=0.0, le=10.0, description="... and the BIM ray cast this far apart, deg; "
                                 "the contenders are fixed again with the whole cloud and the fix's own settings.")
    quick_basin: float = Field(
        2.0, ge=1.0, le=5.0, description="The quick fix's basin is the fix's (max_correction, max_correction_deg) "
                                         "times this: a coarse peak is a cell and a heading step away at best.")
    screened: int = Field(
        12, ge=1, le=100, description="The best coarse peaks whose view is scored at the coarse pose (a ray cast of "
                                      "judge_points, cheap): the fix takes them best first.")
    screen_tolerance: float = Field(
        0.25, gt=0.0, description="At a coarse pose, a point within this of the first surface on its ray is on it, "
                                  "and beyond this seen through it, m: a coarse peak is a cell and a heading step "
                                  "off (7 cm and 1.5 deg: 16 cm at 6 m).")
    screen_slack: float = Field(
        0.15, ge=0.0, le=1.0,
        description="A screened peak is not fixed when its screen score is below the best fix's by more than noise "
                    "and this: a right place's fix scored up to 0.1 above its screen on the tour.")
    candidates: int = Field(
        6, ge=1, le=50, description="At most this many screened peaks are refined by the 4-DoF fix; a peak whose "
                                    "screen score is below the best fix's beyond noise is not.")
    peak_separation: float = Field(0.5, gt=0.0, description="Two coarse peaks nearer than this (m) ...")
    peak_separation_deg: float = Field(15.0, gt=0.0, description="... and this (deg) are one candidate.")
    same_place: float = Field(0.15, gt=0.0, description="Refined candidates nearer than this (m) ...")
    same_place_deg: float = Field(3.0, gt=0.0, description="... and this (deg) converged to the same pose.")
    ambiguity_margin: float = Field(
        0.05, ge=0.0, le=1.0,
        description="A second place whose score is within this of the best's (or within ambiguity_sigmas of its "
                    "noise, if more) fits within noise: the view is ambiguous and no pose is taken.")
    ambiguity_sigmas: float = Field(
        2.0, ge=0.0, description="Standard deviations of a score (a share over the fix's independent_points "
                                 "observations) within which two places are a tie.")
    thing_link: float = Field(
        0.15, gt=0.0, description="Above the floor, two of the view's points within this of each other are one "
                                  "piece of the cloud, m: a person farther than this from a wall is a piece apart.")
    thing_floor: float = Field(
        0.1, ge=0.0, description="Points lower than this above the floor are the floor and join no piece, m (a "
                                 "thing standing on it stays apart from the walls).")
    thing_extent: float = Field(
        2.2, ge=0.0, description="A piece no larger than this across (twice its farthest point from its centroid) "
                                 "is a free-standing thing (a person up to 2.1 m tall, a barrow, a column's "
                                 "face), m; 0: lone points only (each counted on its own anyway).")
    thing_whole: float = Field(
        0.8, ge=0.0, le=1.0,
        description="A thing's points on a surface raise a pose's score only when at least this share of its points "
                    "that meet a surface lie on one (a person partly on a column at a wrong place earns it "
                    "nothing); 0: every point counts on its own.")
    floor_cone_deg: float = Field(
        60.0, gt=0.0, le=85.0,
        description="Without an IMU, the floor's normal is sought within this of the sensor's usual up (a camera "
                    "held level: -y; a scanner: +z): a handheld camera looking down at 50 deg still finds it; "
                    "walls (90 deg off) and ceilings (180) never pass.")
    min_floor_points: int = Field(40, ge=3, description="Fewer thinned points on the floor, and there is none.")
    calibration: OdometryCalibrationConfig = Field(
        default_factory=OdometryCalibrationConfig,
        description="The sweep's online odometry calibration and when a free direction is taken from it.")
