"""Time-of-flight artefacts beyond axial noise: mixed ("flying") pixels at depth steps and dropouts.

**Mixed pixels.** A ToF pixel integrates the modulated light from its whole footprint. Where the footprint
straddles a depth step (an object's silhouette against the wall behind it) the returns mix, and the pixel reports
a depth between the two surfaces: a fringe of points floating in mid-air around every object. For depth steps
well inside the unambiguous range the mixed phase is close to the amplitude-weighted mean of the depths, which
is what we render: pixels next to a step are re-cast with 2 x 2 sub-pixel rays, each weighted by its return
amplitude (IR reflectance x cos incidence / depth^2), and the pixel's depth is their weighted mean.

**Dropouts.** Too little light comes back from surfaces seen at grazing incidence and from dark ones far away:
the sensor reports no depth there. The probability of a dropout rises from 0 to 1 as the incidence goes from
``grazing_deg`` to 88 degrees, and as the return amplitude falls from ``amplitude_high`` to ``amplitude_low``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bim2rdt.perception.camera import Intrinsics

SUBPIXEL_OFFSETS = np.array([[-0.25, -0.25], [0.25, -0.25], [-0.25, 0.25], [0.25, 0.25]])


@dataclass(frozen=True)
class TofEffects:
    """Which time-of-flight artefacts to render, and their thresholds."""

    flying_pixels: bool = True
    dropouts: bool = True
    step: float = 0.02
    """A neighbour this much nearer or farther (m), plus ``step_per_metre`` x depth, marks a pixel as straddling a
    step (it is re-cast). The relative part spares a floor seen at grazing incidence, whose neighbouring pixels
    lie centimetres apart without any step (mixing samples of one plane changes nothing anyway)."""
    step_per_metre: float = 0.02
    grazing_deg: float = 75.0
    """Incidence (deg from the surface normal) where grazing dropouts begin; all are lost by 88 degrees."""
    amplitude_low: float = 0.003
    """Return amplitude (reflectance x cos / m^2) below which no depth comes back."""
    amplitude_high: float = 0.008
    """... and above which every pixel returns (in between the chance falls linearly)."""


def step_pixels(depth: np.ndarray, step: float, step_per_metre: float = 0.0) -> np.ndarray:
    """(H, W) bool: pixels with a 4-neighbour more than ``step`` + ``step_per_metre`` x depth m nearer or
    farther, or a hit next to a miss."""
    edge = np.zeros(depth.shape, dtype=bool)
    for axis in (0, 1):
        a, b = _pairs(depth, axis)
        with np.errstate(invalid="ignore"):
            jump = np.abs(a - b) > step + step_per_metre * np.fmin(a, b)
        jump |= np.isnan(a) != np.isnan(b)
        _mark(edge, jump, axis)
    return edge


def _pairs(depth: np.ndarray, axis: int) -> tuple[np.ndarray, np.ndarray]:
    return (depth[:-1], depth[1:]) if axis == 0 else (depth[:, :-1], depth[:, 1:])


def _mark(edge: np.ndarray, jump: np.ndarray, axis: int) -> None:
    if axis == 0:
        edge[:-1] |= jump
        edge[1:] |= jump
    else:
        edge[:, :-1] |= jump
        edge[:, 1:] |= jump


def subpixel_rays(intrinsics: Intrinsics, us: np.ndarray, vs: np.ndarray) -> np.ndarray:
    """Camera-frame rays (4 n, 3) with z = 1 through the 2 x 2 sub-pixel points of pixels (us, vs), grouped by
    offset (all pixels' first sub-ray, then all second ones ...)."""
    u = (us[None, :] + SUBPIXEL_OFFSETS[:, :1]).ravel()
    v = (vs[None, :] + SUBPIXEL_OFFSETS[:, 1:]).ravel()
    return np.stack([(u - intrinsics.cx) / intrinsics.fx, (v - intrinsics.cy) / intrinsics.fy, np.ones(u.shape)], 1)


def mixed_depth(depths: np.ndarray, amplitudes: np.ndarray) -> np.ndarray:
    """Amplitude-weighted mean (n,) of sub-ray depths (4, n); NaN where no sub-ray returned any light."""
    weights = np.where(np.isfinite(depths), amplitudes, 0.0)
    total = weights.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(total > 0, (weights * np.nan_to_num(depths)).sum(axis=0) / total, np.nan)


def amplitude(reflectance: np.ndarray, cos_incidence: np.ndarray, distance: np.ndarray) -> np.ndarray:
    """Relative ToF return amplitude: IR reflectance x cos(incidence) / distance^2 (1/m^2)."""
    return reflectance * cos_incidence / np.maximum(distance, 1e-3) ** 2


def dropout_chance(cos_incidence: np.ndarray, return_amplitude: np.ndarray, effects: TofEffects) -> np.ndarray:
    """Chance (0-1) that a pixel returns no depth, from its incidence and its return amplitude."""
    incidence = np.rad2deg(np.arccos(np.clip(cos_incidence, 0.0, 1.0)))
    grazing = np.clip((incidence - effects.grazing_deg) / (88.0 - effects.grazing_deg), 0.0, 1.0)
    dark = np.clip((effects.amplitude_high - return_amplitude) / (effects.amplitude_high - effects.amplitude_low),
                   0.0, 1.0)
    return 1.0 - (1.0 - grazing) * (1.0 - dark)
