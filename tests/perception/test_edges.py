"""The planarity-aware flying-pixel filter: mixed pixels at a step go, slanted planes and curved bodies stay."""

from __future__ import annotations

import numpy as np

from bim2rdt.perception.camera import Intrinsics
from bim2rdt.perception.edges import EdgeFilter

CAMERA = Intrinsics(width=160, height=120, fx=130.0, fy=130.0, cx=79.5, cy=59.5)


def _plane_depth(normal, offset) -> np.ndarray:
    """Depth (camera z) of the plane n . X = offset seen through every pixel."""
    rays = CAMERA.pixel_rays()
    with np.errstate(divide="ignore"):
        return offset / (rays @ np.asarray(normal, dtype=float))


def test_a_plane_seen_at_grazing_incidence_keeps_every_pixel():
    """A floor 1.1 m below the camera: neighbouring rows lie centimetres apart, and none of it is an edge."""
    depth = _plane_depth((0.0, 1.0, 0.05), 1.1)
    depth[~np.isfinite(depth) | (depth <= 0) | (depth > 12)] = np.nan
    noisy = depth + np.random.default_rng(0).normal(0, 1, depth.shape) * (0.0015 + 0.0015 * depth)
    assert np.count_nonzero(EdgeFilter().flying(noisy)) < 0.005 * np.count_nonzero(np.isfinite(depth))


def test_mixed_pixels_at_a_step_are_flagged_and_both_surfaces_kept():
    depth = np.full((120, 160), 4.0)
    depth[:, :80] = 3.0
    mixed = np.linspace(3.1, 3.9, 120)  # one fringe column, 10 cm or more off both surfaces
    depth[:, 80] = mixed
    flagged = EdgeFilter().flying(depth)
    assert flagged[:, 80].all()
    assert not flagged[:, 78:80].any() and not flagged[:, 81:83].any()  # the true silhouette pixels stay


def test_a_mixed_pixel_near_the_harmonic_middle_of_a_small_step_is_still_flagged():
    depth = np.full((40, 40), 3.3)
    depth[:, :20] = 3.0
    depth[:, 20] = 3.15  # collinear in 1/z with its two neighbours, 15 cm off both surfaces
    assert EdgeFilter().flying(depth)[:, 20].all()


def test_a_thin_cylinder_keeps_its_pixels():
    """A 2.5 cm tripod leg at 3 m, 4-5 pixels wide (VGA): curvature is far below the noise tolerance."""
    depth = np.full((60, 640), 6.0)
    u = np.arange(640)
    x = (u - 319.5) / 525.0 * 3.0
    on_leg = np.abs(x) < 0.0125
    depth[:, on_leg] = 3.0 - np.sqrt(0.0125 ** 2 - x[on_leg] ** 2)
    flagged = EdgeFilter().flying(depth)
    assert np.count_nonzero(flagged[:, on_leg]) == 0


def test_apply_sets_flying_pixels_to_no_return_and_keeps_the_rest():
    depth = np.full((20, 20), 4.0, dtype=np.float32)
    depth[:, :10] = 2.0
    depth[:, 10] = 3.0
    filtered = EdgeFilter().apply(depth)
    assert np.isnan(filtered[:, 10]).all() and np.isfinite(filtered[:, :10]).all() and np.isfinite(filtered[:, 11:]).all()
