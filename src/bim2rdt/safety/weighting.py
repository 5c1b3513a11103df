"""The hand-arm frequency weighting Wh (ISO 5349-1 Annex A, exact analog form of ISO 8041-1) and its r.m.s.

Wh is the product of a 2nd-order Butterworth band-limit high-pass (f1 = 10^0.8 Hz), a 2nd-order Butterworth
band-limit low-pass (f2 = 10^3.1 Hz) and an acceleration-velocity transition (f3 = f4 = 100/(2 pi) Hz,
Q4 = 0.64). We apply the *exact* analog response in the frequency domain instead of a digital IIR: a plain
bilinear IIR at fs = 5 kHz is -21.8 % at 1 kHz (outside the ISO 8041-1 tolerance), whereas the analog response
sampled on the FFT grid is exact at any sampling rate. The signal is zero-padded by :data:`SETTLE_S` so the
weighting's impulse response (the 6.3 Hz high-pass decays to 1e-6 in about 0.5 s) never wraps round.

A sensor sampled at fs only sees frequencies below fs/2: a smartwatch IMU at 800 Hz covers the one-third-octave
bands 8 to 315 Hz and misses the 400-1000 Hz bands; :func:`covered_band` says which bands a rate covers and
results from such sensors carry that flag.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft

from bim2rdt.safety.errors import HavError

F1_HZ = 10**0.8
F2_HZ = 10**3.1
F4_HZ = 100.0 / (2.0 * np.pi)
Q1 = Q2 = 1.0 / np.sqrt(2.0)
Q4 = 0.64
SETTLE_S = 0.7
"""Zero padding, seconds: longer than the weighting's impulse response (decays below 1e-7 by 0.7 s)."""
NOMINAL_BANDS = (9, 30)
"""ISO 5349-1 nominal range as one-third-octave band numbers n (centre 10^(n/10) Hz): 8 Hz to 1000 Hz."""
MIN_FS_HZ = 2.0 * 10 ** ((NOMINAL_BANDS[0] + 0.5) / 10)
"""Slowest usable sampling rate, Hz (17.8): below it the Nyquist frequency lies under the 8 Hz band's upper edge
and the rate covers no Wh band at all."""


def wh_response(freq_hz: np.ndarray | float) -> np.ndarray:
    """Complex Wh at frequencies in Hz (0 at DC): H_h * H_l * H_t of ISO 8041-1 with s = j 2 pi f."""
    f = np.asarray(freq_hz, dtype=float)
    s = 2j * np.pi * f
    w1, w2, w4 = 2 * np.pi * F1_HZ, 2 * np.pi * F2_HZ, 2 * np.pi * F4_HZ
    # H_h = s^2 / (s^2 + w1 s / Q1 + w1^2): the same as 1/(1 + w1/(Q1 s) + (w1/s)^2) but defined at s = 0
    high = s**2 / (s**2 + w1 * s / Q1 + w1**2)
    low = 1.0 / (1.0 + s / (Q2 * w2) + (s / w2) ** 2)
    transition = (1.0 + s / w4) / (1.0 + s / (Q4 * w4) + (s / w4) ** 2)
    return high * low * transition


def wh_weighting_factor(freq_hz: np.ndarray | float) -> np.ndarray | float:
    """The ISO 5349-1 hand-arm weighting's magnitude: 0.2020 at 79.577 Hz (500 rad/s), 0.8766 at exactly 8 Hz.

    Args:
        freq_hz: Frequency or frequencies, Hz.

    Returns:
        |Wh(f)|, a float for a scalar frequency, else an array of the same shape.
    """
    factor = np.abs(wh_response(freq_hz))
    return float(factor) if np.ndim(factor) == 0 else factor


def band_centre_hz(n: int | np.ndarray) -> np.ndarray | float:
    """Exact one-third-octave band centre 10^(n/10) Hz of band number n (n = 9 is the nominal 8 Hz band)."""
    return np.power(10.0, np.asarray(n, dtype=float) / 10.0)


@dataclass(frozen=True)
class BandCoverage:
    """Which one-third-octave bands a sampling rate resolves; ``complete`` when it covers 8 to 1000 Hz."""

    fs: float
    low_hz: float
    high_hz: float
    complete: bool


def covered_band(fs: float) -> BandCoverage:
    """The one-third-octave bands a sampling rate resolves: those whose upper edge 10^((n+0.5)/10) Hz lies
    below Nyquist (800 Hz sampling covers 8 to 316 Hz).

    Args:
        fs: Sampling rate, Hz.

    Returns:
        The lowest and highest band centre covered (Hz; NaN when none) and whether 8 to 1000 Hz is complete.

    Raises:
        HavError: A rate that is not a positive number.
    """
    _check_rate(fs)
    bands = np.arange(NOMINAL_BANDS[0], NOMINAL_BANDS[1] + 1)
    upper_edges = band_centre_hz(bands + 0.5)
    inside = bands[upper_edges <= fs / 2.0]
    if inside.size == 0:
        return BandCoverage(fs, float("nan"), float("nan"), False)
    return BandCoverage(fs, float(band_centre_hz(inside[0])), float(band_centre_hz(inside[-1])),
                        bool(inside[-1] == NOMINAL_BANDS[1]))


def weighting_power(n_fft: int, fs: float, gain: np.ndarray | None = None) -> np.ndarray:
    """|Wh(f)|^2 (times an optional mounting gain^2) on the rfft grid of ``n_fft`` points at ``fs`` Hz."""
    freqs = scipy.fft.rfftfreq(n_fft, 1.0 / fs)
    power = np.abs(wh_response(freqs)) ** 2
    return power if gain is None else power * np.asarray(gain) ** 2


def weighted_rms(accel: np.ndarray, fs: float) -> float:
    """Wh-weighted r.m.s. (m/s^2) of one axis of acceleration ``accel`` (m/s^2) sampled at ``fs`` Hz.

    The mean (gravity, sensor offset) is removed first (Wh is 0 at DC), the signal is zero-padded by
    :data:`SETTLE_S` and the weighted energy is summed over the rfft grid (Parseval): the energy of the linearly
    filtered signal, divided by the sampled duration.

    Args:
        accel: (n,) acceleration along one axis, m/s^2.
        fs: Sampling rate, Hz.

    Returns:
        The Wh-weighted r.m.s. acceleration, m/s^2.

    Raises:
        HavError: A signal that is not 1-D with at least 2 samples, or a bad rate.
    """
    x = _as_signal(accel, fs)
    n_fft = scipy.fft.next_fast_len(x.size + int(np.ceil(SETTLE_S * fs)), real=True)
    spectrum = scipy.fft.rfft(x - x.mean(), n_fft)
    energy = _one_sided_energy(np.abs(spectrum) ** 2 * weighting_power(n_fft, fs), n_fft)
    return float(np.sqrt(energy / x.size))


def _one_sided_energy(power: np.ndarray, n_fft: int) -> np.ndarray:
    """Time-domain energy sum(x^2) from a one-sided |X_k|^2 (last axis) by Parseval."""
    interior_end = power.shape[-1] - 1 if n_fft % 2 == 0 else power.shape[-1]
    total = power[..., 0] + 2.0 * power[..., 1:interior_end].sum(axis=-1)
    if n_fft % 2 == 0:
        total = total + power[..., -1]
    return total / n_fft


def _as_signal(accel: np.ndarray, fs: float) -> np.ndarray:
    _check_rate(fs)
    x = np.asarray(accel, dtype=float)
    if x.ndim != 1 or x.size < 2:
        raise HavError(f"expected a 1-D acceleration signal of at least 2 samples, got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise HavError("acceleration signal contains NaN or infinite samples")
    return x


def _check_rate(fs: float) -> None:
    if not np.isfinite(fs) or fs <= 0:
        raise HavError(f"sampling rate must be a positive number of Hz, got {fs!r}")


def require_weighable_rate(fs: float) -> None:
    """HavError unless ``fs`` is finite and covers at least the lowest Wh band (``MIN_FS_HZ``)."""
    if not MIN_FS_HZ <= fs < np.inf:  # also false for NaN
        raise HavError(f"sampling rate {fs:g} Hz is unusable: the lowest Wh band (8 Hz) needs at least "
                       f"{MIN_FS_HZ:.1f} Hz")
