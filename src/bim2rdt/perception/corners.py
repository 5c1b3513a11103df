"""Shi-Tomasi corners inside a region of interest (the paper's corner step, ``cv2.goodFeaturesToTrack``).

A pixel is a corner when the smaller eigenvalue of its gradient second-moment matrix is at least
``quality`` x the image's best; non-maximum suppression keeps corners ``min_distance`` pixels apart, and the
strongest ``max_corners`` are returned. The paper's values: quality 0.01-0.05, radius 3 px, K = 600.
"""

from __future__ import annotations

import cv2
import numpy as np


def shi_tomasi(gray: np.ndarray, roi: tuple[int, int, int, int], max_corners: int = 600,
               quality: float = 0.01, min_distance: float = 3.0, within: np.ndarray | None = None) -> np.ndarray:
    """Corner pixels (N, 2) as float (u, v) inside ``roi`` = (u0, v0, u1, v1) (exclusive ends) of a uint8 image,
    and inside the bool mask ``within`` (the image's size) when one is given."""
    u0, v0, u1, v1 = roi
    mask = np.zeros(gray.shape, dtype=np.uint8)
    mask[v0:v1, u0:u1] = 255
    if within is not None:
        mask[~within] = 0
    corners = cv2.goodFeaturesToTrack(gray, maxCorners=max_corners, qualityLevel=quality,
                                      minDistance=min_distance, mask=mask)
    return np.zeros((0, 2)) if corners is None else corners.reshape(-1, 2).astype(np.float64)
