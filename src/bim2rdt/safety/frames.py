"""Analysis frames of the streaming monitor: sine-tapered, 50 % overlapped, weighted in the frequency domain.

A sine window w[n] = sin(pi (n + 1/2) / N) has w^2 = periodic Hann, and Hann frames at a hop of N/2 sum to
exactly 1, so every sample's energy is counted once however the stream is cut into frames (weighted
overlap-add). Each frame's weighted energy comes from Parseval with the exact analog |Wh|^2 (see
:mod:`bim2rdt.safety.weighting`); the taper keeps leakage from the steep 6.3 Hz skirt below 0.6 % at the 8 Hz
band. Frames are about 0.8 s long (a power of two), so frequency resolution is about 1.2 Hz at any rate.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import scipy.fft

from bim2rdt.safety.weighting import weighting_power

FRAME_S = 0.8
"""Target frame length, seconds (rounded to a power of two of samples)."""
NAN, SATURATION, SHOCK = 1, 2, 4
"""Artefact flag bits of a frame (ISO 8041-2 style automatic artefact rejection)."""
ARTEFACT_NAMES = {NAN: "nan", SATURATION: "saturation", SHOCK: "shock"}


@dataclass(frozen=True)
class FrameSpec:
    """Frame geometry at one sampling rate: ``length`` samples, hop ``length // 2``."""

    fs: float
    length: int

    @classmethod
    def for_rate(cls, fs: float) -> FrameSpec:
        return cls(float(fs), max(64, 2 ** int(round(np.log2(FRAME_S * fs)))))

    @property
    def hop(self) -> int:
        return self.length // 2


@dataclass(frozen=True)
class ArtefactLimits:
    """When a frame is rejected: peaks at ``saturation_ratio`` of full scale, or a crest factor above
    ``crest_limit`` with a peak over ``shock_min_peak`` m/s^2 (a knock on the sensor, not tool vibration)."""

    saturation_ratio: float = 0.98
    crest_limit: float = 25.0
    shock_min_peak: float = 100.0


@lru_cache(maxsize=16)
def sine_window(length: int) -> np.ndarray:
    """The sine (square-root periodic Hann) window of ``length`` samples, float32."""
    return np.sin(np.pi * (np.arange(length) + 0.5) / length).astype(np.float32)


def energy_weights(spec: FrameSpec, gain: np.ndarray | None = None) -> np.ndarray:
    """Per-rfft-bin factors turning |X_k|^2 of a frame into weighted energy sum(a_w^2) dt (m^2/s^3)."""
    power = weighting_power(spec.length, spec.fs, gain)
    parseval = np.full(power.shape, 2.0)
    parseval[0] = 1.0
    if spec.length % 2 == 0:
        parseval[-1] = 1.0
    return (power * parseval / spec.length / spec.fs).astype(np.float32)


def frame_energies(frames: np.ndarray, spec: FrameSpec, weights: np.ndarray) -> np.ndarray:
    """Weighted energy (m^2/s^3) per frame and axis of ``frames`` (F, 3, N) float32 -> (F, 3) float64."""
    centred = frames - frames.mean(axis=-1, keepdims=True)
    spectrum = scipy.fft.rfft(centred * sine_window(spec.length), axis=-1)
    power = spectrum.real**2 + spectrum.imag**2
    return (power @ weights).astype(np.float64)


def artefact_flags(frames: np.ndarray, full_scale: np.ndarray, limits: ArtefactLimits) -> np.ndarray:
    """Bit flags (F,) of NaN, saturation and shock artefacts in ``frames`` (F, 3, N), m/s^2.

    ``full_scale`` (F,) is each frame's sensor range in m/s^2 (inf when unknown). NaN frames are zeroed in
    place so they can still go through the FFT; they are rejected anyway.
    """
    flags = np.zeros(frames.shape[0], dtype=np.int64)
    bad = ~np.isfinite(frames).all(axis=(1, 2))
    if bad.any():
        flags[bad] |= NAN
        frames[bad] = 0.0
    top, bottom = frames.max(axis=-1), frames.min(axis=-1)
    peak = np.maximum(top, -bottom).max(axis=-1)
    flags[peak >= limits.saturation_ratio * full_scale] |= SATURATION
    mean = frames.mean(axis=-1)
    centred_peak = np.maximum(top - mean, mean - bottom)
    rms = np.sqrt(np.maximum(np.einsum("fan,fan->fa", frames, frames) / frames.shape[-1] - mean**2, 1e-12))
    shock = ((centred_peak > limits.crest_limit * rms) & (centred_peak > limits.shock_min_peak)).any(axis=-1)
    flags[shock] |= SHOCK
    return flags


def describe_flags(flags: int) -> list[str]:
    """Names of the artefacts in a flag word, e.g. ['saturation', 'shock']."""
    return [name for bit, name in ARTEFACT_NAMES.items() if flags & bit]
