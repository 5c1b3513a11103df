"""An organised PCD's pinhole, fitted from its own points (closed-form least squares): recovered to the 1e-4 px the
intrinsics keep, agreeing with lstsq, and refused where the cloud is no pinhole image or holds too few points."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.sources.errors import SourceError
from bim2rdt.sources.pcd_frame import _line_fit, fit_intrinsics


def organised(fx=525.3, fy=523.9, cx=318.7, cy=241.2, width=64, height=48, warp=0.0, seed=0):
    """(H, W, 3) points of a pinhole camera seeing a bumpy wall, NaN holes; ``warp`` bends u by pixels."""
    rng = np.random.default_rng(seed)
    v, u = np.mgrid[0:height, 0:width].astype(float)
    z = 2.0 + 0.3 * rng.random((height, width))
    xyz = np.stack([(u + warp * (u / width) ** 2 - cx) / fx * z, (v - cy) / fy * z, z], axis=-1)
    xyz[rng.random((height, width)) < 0.2] = np.nan
    return xyz


def test_the_pinhole_is_recovered():
    got = fit_intrinsics("f.pcd", organised(cx=30.2, cy=22.7))
    assert (got.width, got.height) == (64, 48)
    assert (got.fx, got.fy, got.cx, got.cy) == (525.3, 523.9, 30.2, 22.7)


def test_the_closed_form_is_lstsq():
    rng = np.random.default_rng(3)
    slope = rng.uniform(-0.6, 0.6, 5000)
    pixel = np.round(524.77 * slope + 319.41 + rng.normal(0, 0.2, 5000))
    f, c, worst = _line_fit(slope, pixel)
    A = np.stack([slope, np.ones_like(slope)], axis=1)
    (want_f, want_c), *_ = np.linalg.lstsq(A, pixel, rcond=None)
    assert abs(f - want_f) < 1e-9 and abs(c - want_c) < 1e-9
    assert worst == pytest.approx(np.abs(A @ (want_f, want_c) - pixel).max(), abs=1e-9)


def test_a_bent_cloud_and_a_nearly_empty_one_are_refused():
    with pytest.raises(SourceError, match="not a pinhole image"):
        fit_intrinsics("f.pcd", organised(warp=8.0))
    empty = organised()
    empty[:, 3:] = np.nan
    empty[10:, :] = np.nan  # 30 valid points
    with pytest.raises(SourceError, match="too few to fit"):
        fit_intrinsics("f.pcd", empty)
