"""A detection's world points, the paper's way: Shi-Tomasi corners in its ROI (and mask), their depth, back-
projected to the world; minus flying pixels and what the BIM's building explains (wall and slab corners in the
box are clutter the BIM can name).

Unusable detections get a one-line reason instead of points: an ROI off the image, a mask of another size, no
corner with a valid depth.
"""

from __future__ import annotations

import cv2
import numpy as np

from bim2rdt.perception.background import BimStructure, explained
from bim2rdt.perception.corners import shi_tomasi
from bim2rdt.perception.detection import Detection
from bim2rdt.perception.edges import EdgeFilter, depth_at
from bim2rdt.perception.frame import Frame


def checked_roi(detection: Detection, frame: Frame) -> tuple[tuple[int, int, int, int] | None, str | None]:
    """The detection's ROI clipped to the image, or None and the reason it cannot be used."""
    width, height = frame.intrinsics.width, frame.intrinsics.height
    if detection.bbox is None:
        return None, f"{detection.family}: no ROI"
    try:
        u0, v0, u1, v1 = (int(round(float(c))) for c in detection.bbox)
    except (TypeError, ValueError):
        return None, f"{detection.family}: ROI {detection.bbox!r} is not four numbers"
    clipped = (max(u0, 0), max(v0, 0), min(u1, width), min(v1, height))
    if clipped[0] >= clipped[2] or clipped[1] >= clipped[3]:
        return None, f"{detection.family}: ROI {(u0, v0, u1, v1)} lies off the {width}x{height} image"
    if detection.mask is not None and np.shape(detection.mask) != (height, width):
        return None, f"{detection.family}: mask of shape {np.shape(detection.mask)} for a {width}x{height} image"
    return clipped, None


def detection_points(frame: Frame, depth: np.ndarray, detection: Detection, structure: BimStructure,
                     slab_height: float, slab_clearance: float, noise: EdgeFilter, max_corners: int = 600,
                     mask_margin: int = 3, mask_points: int = 0) -> tuple[np.ndarray, str | None]:
    """World points (N, 3) of a detection's corners with valid ``depth`` (the frame's, flying pixels removed),
    plus up to ``mask_points`` pixels spread evenly over its mask, less those the BIM's building explains
    (within ``slab_clearance`` plus 3 sigma of depth noise of its surfaces: tight, so a cone's 3 cm base plate,
    which gives its yaw, is not taken for slab); (empty, reason) when there are none."""
    roi, reason = checked_roi(detection, frame)
    if roi is None:
        return np.zeros((0, 3)), reason
    within = None
    if detection.mask is not None:
        grown = cv2.dilate(np.asarray(detection.mask, dtype=np.uint8), np.ones((2 * mask_margin + 1,) * 2, np.uint8))
        within = grown.astype(bool)
    uv = shi_tomasi(frame.gray, roi, max_corners=max_corners, within=within)
    if mask_points > 0 and detection.mask is not None:
        uv = np.vstack([uv, _spread(np.asarray(detection.mask, dtype=bool) & np.isfinite(depth), roi, mask_points)])
    z = depth_at(depth, uv)
    ok = np.isfinite(z) & (z > 0)
    if not ok.any():
        return np.zeros((0, 3)), f"{detection.family}: no corner in ROI {roi} has a valid depth"
    T = frame.require_pose("back-projecting a detection to the world")
    rays = frame.intrinsics.backproject(uv[ok], np.ones(int(ok.sum())))
    directions = rays @ T[:3, :3].T
    z_ok = z[ok].astype(float)
    sigma = noise.noise + noise.noise_per_metre * z_ok
    keep = ~explained(structure, T[:3, 3], directions, z_ok, slab_clearance, sigma, slab_height, slab_clearance)
    points = T[:3, 3] + directions[keep] * z[ok][keep, None]
    if len(points) == 0:
        return points, f"{detection.family}: every corner in ROI {roi} lies on the BIM's building"
    return points, None


def _spread(mask: np.ndarray, roi: tuple[int, int, int, int], count: int) -> np.ndarray:
    """Up to ``count`` pixels (u, v) of ``mask`` inside ``roi``, evenly spread over them (every k-th)."""
    u0, v0, u1, v1 = roi
    vs, us = np.nonzero(mask[v0:v1, u0:u1])
    pick = np.unique(np.linspace(0, len(us) - 1, min(count, len(us))).astype(int)) if len(us) else []
    return np.c_[us[pick] + u0, vs[pick] + v0].astype(float)
