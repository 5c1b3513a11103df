"""A plane fit of a frame's own depth points (RANSAC, then least squares on the inliers): the test's truth for
which way the floor faces and how high the camera is, independent of what a reader says."""

from __future__ import annotations

import numpy as np


def camera_points(frame, rows: slice = slice(None)) -> np.ndarray:
    """(N, 3) camera-frame points of the frame's valid depth pixels in image ``rows``."""
    valid = frame.valid_depth.copy()
    keep = np.zeros_like(valid)
    keep[rows] = True
    return (frame.intrinsics.pixel_rays() * frame.depth[..., None].astype(np.float64))[valid & keep]


def fit_plane(points: np.ndarray, tolerance: float = 0.01, trials: int = 1500, seed: int = 0):
    """(unit normal (3,) facing the camera, distance from the camera (m), inlier fraction) of the plane with most
    points within ``tolerance``."""
    rng = np.random.default_rng(seed)
    best, best_count = None, 0
    sample = points[rng.choice(len(points), min(len(points), 20_000), replace=False)]
    for a, b, c in sample[rng.integers(0, len(sample), (trials, 3))]:
        normal = np.cross(b - a, c - a)
        if np.linalg.norm(normal) < 1e-9:
            continue
        normal /= np.linalg.norm(normal)
        count = int((np.abs(sample @ normal - normal @ a) < tolerance).sum())
        if count > best_count:
            best, best_count = (normal, float(normal @ a)), count
    normal, offset = best
    inliers = points[np.abs(points @ normal - offset) < tolerance]
    centre = inliers.mean(axis=0)
    normal = np.linalg.svd(inliers - centre, full_matrices=False)[2][2]
    if normal @ centre > 0:  # face the camera (at the origin)
        normal = -normal
    return normal, float(abs(normal @ centre)), len(inliers) / len(points)
