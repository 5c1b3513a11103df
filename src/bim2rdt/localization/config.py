"""The knobs of BIM-anchored localization, one validated object. Lengths in metres, angles in degrees.

Defaults suit a quadruped's RGB-D camera (VGA, time-of-flight noise 1.5 mm + 1.5 mm/m) at 1-8 m from walls,
columns and slabs, with a prior from legged odometry that drifts 2 % of the distance and ~1 degree per 10 m
since the last fix (a few decimetres between stations).
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field


class LocalizationConfig(BaseModel):
    """Parameters of :func:`bim2rdt.localization.localize`."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    pixel_stride: int = Field(
        8, ge=1, le=64,
        description="Use every n-th depth pixel in both directions (VGA at 8: 80 x 60 = 4,800 points). Surfaces "
                    "are large; more points cost time, not accuracy.")
    min_range: float = Field(0.3, gt=0.0, description="Depth returns nearer than this are ignored, m.")
    max_range: float = Field(
        8.0, gt=0.0,
        description="Depth returns farther than this are ignored, m: ToF noise (1.5 mm + 1.5 mm/m) and mixed "
                    "pixels grow with range, and distant returns are often through openings, off the model.")
    model_stride: int = Field(
        4, ge=1, le=64,
        description="Pixel stride of the BIM ray cast that samples the visible permanent surface (twice as dense "
                    "as the depth points at the defaults, so every depth point has a sample nearby) for the polish "
                    "and the judgement of the fix.")
    coarse_model_stride: int = Field(
        8, ge=1, le=64,
        description="Pixel stride of the ray cast for the coarse pass from the prior. Its pairs reach to the basin "
                    "and its Huber scale anneals from there, so a quarter of the polish's samples do (the same "
                    "fixes on the tour, and 40 % of a frame's time saved: the k-d trees and queries scale with "
                    "the samples).")
    view_margin: float = Field(
        0.25, ge=0.0, le=2.0,
        description="The BIM is ray cast over a field of view this fraction wider on each side than the camera's, so "
                    "surfaces the true camera sees but the prior's view just misses are in the model.")
    max_correction: float = Field(
        0.6, gt=0.0,
        description="The basin: a fix that moves the camera farther than this from the prior is rejected, m. "
                    "Pairs farther apart than this are never matched.")
    max_correction_deg: float = Field(6.0, gt=0.0, le=90.0, description="The basin in yaw, degrees.")
    huber_delta: float = Field(
        0.015, gt=0.0, description="Final Huber scale, m: about 2 sigma of ToF depth noise at 4 m.")
    normal_gate_deg: float = Field(
        45.0, gt=0.0, le=90.0,
        description="A depth point and the BIM sample it is paired with must face the same way within this angle "
                    "(PCA normals of dense depth are good); 90 = off. Keeps points on a column's side off its front.")
    max_iterations: int = Field(30, ge=1, le=500, description="Iteration cap of the coarse pass.")
    polish_iterations: int = Field(
        10, ge=0, le=500,
        description="Iterations of a second pass with the BIM ray cast again from the coarse fix (0 = off): the "
                    "visible surface of the true view, not the prior's.")
    inlier_distance: float = Field(
        0.03, gt=0.0, description="A depth point within this of a permanent surface after the fix is an inlier, m.")
    min_points: int = Field(
        150, ge=6,
        description="Fewer depth points than this within the basin of a visible permanent surface at the prior, and "
                    "the frame does not see the map (facing an open slab edge, a tarp, the sky).")
    min_inliers: int = Field(100, ge=6, description="Fewer inliers than this after the fix, and the fix is rejected.")
    min_inlier_fraction: float = Field(
        0.5, ge=0.0, le=1.0,
        description="Fewer of the points near the map than this fraction on it after the fix, and the fix is "
                    "rejected: ICP stopped in a wrong minimum (the prior was beyond the basin). Right fixes on the "
                    "tour, people and moved site objects in view, put 92-100 % there.")
    behind_tolerance: float = Field(
        0.1, gt=0.0, description="A depth point farther than this beyond the first permanent surface on its ray "
                                 "(from the fixed pose) lies behind the map, m.")
    max_behind_fraction: float = Field(
        0.15, ge=0.0, le=1.0,
        description="More depth points than this fraction behind the map, and the fix is rejected: a camera cannot "
                    "see through walls, so ICP stopped in a wrong place. Raise it on a site where many walls of "
                    "the model are not built yet.")
    degenerate_sigma: float = Field(
        0.1, gt=0.0,
        description="A direction the view pins no better than this (1 sigma, m; turns in metres at the points' "
                    "lever arm) cannot be fixed by it: a single long wall leaves the position along it free "
                    "(exactly no information), a column and a wall 6 m off pin their weakest direction to ~3 cm.")
    surface_sigma: float = Field(
        0.01, gt=0.0,
        description="Standard deviation of a surface's as-built position against the BIM (construction tolerance), "
                    "m; the covariance never assumes depth points are better than the walls they lie on.")
    independent_points: int = Field(
        50, ge=1,
        description="How many independent observations a view is worth: depth errors are correlated within a "
                    "surface (calibration, tolerance), so thousands of points are not thousands of measurements.")
    imu_tilt_sigma_deg: float = Field(
        0.2, gt=0.0, description="Roll and pitch come from the IMU; their standard deviation in the covariance, deg.")
    unconstrained_sigma: float = Field(
        100.0, gt=0.0, description="Standard deviation reported along a direction the view cannot fix, m (or rad).")
    look_around_deg: tuple[float, ...] = Field(
        (70.0, -70.0),
        description="Turns (deg, from the station's heading, tried in order) for another look when a station's fix "
                    "leaves a direction free or is refused; empty = never look around.")
    cloud_voxel: float = Field(
        0.05, gt=0.0,
        description="localize_cloud thins the cloud to one point per cube of this size, m: surfaces, not the "
                    "sensor's sampling (dense near it), weigh in the fix.")
    cloud_points: int = Field(
        6000, ge=100, description="localize_cloud uses at most this many thinned points (an even draw).")
    cloud_normal_neighbours: int = Field(
        12, ge=4, le=64, description="Neighbours of a thinned point whose spread gives its normal (PCA).")
    cloud_ray_deg: float = Field(
        0.5, gt=0.0, le=10.0,
        description="Angular spacing of the rays localize_cloud casts at the BIM from the sensor, degrees (the coarse "
                    "pass twice that): 0.5 deg is 4 cm at 5 m, as dense as the thinned points.")
    cloud_margin_deg: float = Field(
        8.0, ge=0.0, le=90.0,
        description="localize_cloud keeps the BIM's surface in the directions the cloud covers, widened by this, "
                    "degrees: what the true pose sees but the prior's just misses (the yaw basin and then some).")
