"""A planarity-aware filter for time-of-flight mixed ("flying") pixels.

Where a pixel's footprint straddles a depth step, a ToF camera reports a depth between the two surfaces: a
fringe of points in mid-air around every silhouette, and Shi-Tomasi corners sit exactly on silhouettes. A plain
edge filter (drop every pixel next to a large depth difference) also eats slanted surfaces, whose neighbouring
pixels differ by centimetres at grazing incidence: the floor ahead, a wall seen along its length.

The test here is planarity: on a plane, inverse depth 1/z is an affine function of the pixel (u, v), so three
pixels in a row on one surface have a zero second difference of 1/z. A pixel on a real surface, even at a
silhouette, has a run of three on its own side (left or right, up or down) that is collinear within the noise;
a mixed pixel belongs to neither side, so both one-sided runs bend. A pixel is flagged when, along either image
axis, it differs from a neighbour by more than noise allows and neither one-sided run through it is collinear.
The centred run is not used: a mixed pixel near the harmonic middle of a small step is collinear with its
two neighbours while floating centimetres off both surfaces.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict


class EdgeFilter(BaseModel):
    """Depth noise model (sigma_z = ``noise`` + ``noise_per_metre`` x z, m; a ToF camera's defaults) and the
    number of sigmas a second difference or a neighbour step may reach before it counts."""

    model_config = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)

    noise: float = 0.0015
    noise_per_metre: float = 0.0015
    sigmas: float = 3.0

    def flying(self, depth: np.ndarray) -> np.ndarray:
        """Find the flying pixels: depths that mix two surfaces at a silhouette (or isolated returns).

        Args:
            depth: (H,W) depth image, metres; 0 or NaN is no return.

        Returns:
            (H,W) bool, True at flying pixels.
        """
        depth = np.where(np.isfinite(depth) & (depth > 0), depth, np.nan)
        inverse = 1.0 / depth
        sigma_inverse = (self.noise + self.noise_per_metre * depth) / depth ** 2
        tolerance = self.sigmas * np.sqrt(6.0) * sigma_inverse  # a second difference of three noisy samples
        jump = self.sigmas * np.sqrt(2.0) * sigma_inverse  # a difference of two
        flagged = np.zeros(depth.shape, dtype=bool)
        for axis in (0, 1):
            flagged |= _bent_at_a_step(inverse, tolerance, jump, axis)
        return flagged & np.isfinite(depth)

    def apply(self, depth: np.ndarray) -> np.ndarray:
        """Remove the flying pixels from a depth image.

        Args:
            depth: (H,W) depth image, metres; 0 or NaN is no return.

        Returns:
            (H,W) float32 copy of ``depth`` with flying pixels set to NaN (no return).
        """
        out = np.array(depth, dtype=np.float32, copy=True)
        out[self.flying(depth)] = np.nan
        return out


def depth_at(depth: np.ndarray, uv: np.ndarray, radius: int = 1) -> np.ndarray:
    """Depth (N,) at pixels ``uv`` (N, 2) of a filtered depth image: the pixel's own, or, where it has none (a
    flying pixel removed, a dropout), the nearest surface within ``radius`` pixels. Shi-Tomasi puts corners on
    silhouettes, exactly where the mixed pixels were; the near side is the object whose outline made the corner,
    a pixel away at most. NaN where nothing within reach returned."""
    height, width = depth.shape
    u = np.clip(np.round(uv[:, 0]).astype(int), 0, width - 1)
    v = np.clip(np.round(uv[:, 1]).astype(int), 0, height - 1)
    own = depth[v, u].astype(float)
    missing = ~(np.isfinite(own) & (own > 0))
    if not missing.any():
        return own
    valid = np.where(np.isfinite(depth) & (depth > 0), depth, np.inf)
    padded = np.pad(valid, radius, constant_values=np.inf)
    best = np.full(int(missing.sum()), np.inf)
    for dv in range(-radius, radius + 1):
        for du in range(-radius, radius + 1):
            best = np.minimum(best, padded[v[missing] + radius + dv, u[missing] + radius + du])
    own[missing] = np.where(np.isfinite(best), best, np.nan)
    return own


def _bent_at_a_step(inverse: np.ndarray, tolerance: np.ndarray, jump: np.ndarray, axis: int) -> np.ndarray:
    """Along ``axis``: a neighbour differs by more than ``jump`` and neither one-sided run of three is straight."""
    w = np.moveaxis(inverse, axis, 0)
    tol, step = np.moveaxis(tolerance, axis, 0), np.moveaxis(jump, axis, 0)
    padded = np.pad(w, ((2, 2), (0, 0)), constant_values=np.nan)
    prev2, prev1, here, next1, next2 = (padded[k:k + len(w)] for k in range(5))
    with np.errstate(invalid="ignore"):
        straight_before = np.abs(prev2 - 2 * prev1 + here) <= tol
        straight_after = np.abs(here - 2 * next1 + next2) <= tol
        stepped = (np.abs(here - prev1) > step) | (np.abs(here - next1) > step)
    bent = stepped & ~straight_before & ~straight_after
    return np.moveaxis(bent, 0, axis)
