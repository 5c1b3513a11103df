"""Mounting correction: map a wearable's reading (wrist, forearm, ...) to what ISO 5349 measures at the hand.

A wrist or arm sensor sees vibration after the hand and wrist have damped it, more at high frequency. The
correction is a per-subject, per-position gain G(f) fitted from paired recordings (the ISO position, e.g. the
tool handle or palm, recorded together with the wearable position): in each one-third-octave band from 6.3 Hz
to 1250 Hz, G = sqrt(P_reference / P_wearable) from Welch spectra summed over the three axes, interpolated
linearly in log-frequency between band centres. It is applied before the Wh weighting (in the streaming monitor
as a linear-phase FIR, :meth:`MountingCorrection.fir`). A
corrected figure is still an estimate (HSE: no wrist device measures to ISO 5349) and is labelled so.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np
import scipy.signal

from bim2rdt.safety.errors import HavError
from bim2rdt.safety.weighting import band_centre_hz

FIR_TAPS = 255
"""Taps of the linear-phase FIR that realises G(f) in the streaming monitor (about fs / 255 Hz resolution)."""
FIT_BANDS = np.arange(8, 32)
"""One-third-octave bands fitted: n = 8 (6.3 Hz) to n = 31 (1250 Hz)."""
_EMPTY_BAND = 1e-9
"""A band with less than this fraction of the strongest band's power carries no information."""


@dataclass(frozen=True)
class MountingCorrection:
    """Band gains (reference / wearable amplitude) of one subject at one wearable position."""

    subject: str
    position: str
    band_hz: tuple[float, ...]
    gain: tuple[float, ...]

    @classmethod
    def fit(cls, reference: np.ndarray, wearable: np.ndarray, fs: float, subject: str,
            position: str) -> MountingCorrection:
        """Fit the band gains from simultaneous recordings of a reference sensor and the wearable.

        Args:
            reference: (n,3) reference accelerations, m/s^2.
            wearable: (n,3) wearable accelerations over the same time, m/s^2.
            fs: Sampling rate of both, Hz.
            subject: Whose hand the recordings are of.
            position: Where the wearable sat.

        Returns:
            The correction: one gain per one-third-octave band with vibration in both.

        Raises:
            HavError: Recordings not both (n,3), with NaN or infinite samples, or sharing too little vibration.
        """
        ref, wear = _paired(reference, wearable)
        nperseg = 2 ** int(round(np.log2(0.8 * fs)))  # about 1.2 Hz resolution at any rate
        freqs, p_ref = scipy.signal.welch(ref, fs, nperseg=nperseg, axis=0)
        _, p_wear = scipy.signal.welch(wear, fs, nperseg=nperseg, axis=0)
        bands = FIT_BANDS[band_centre_hz(FIT_BANDS + 0.5) <= fs / 2]
        ref_band = _band_power(freqs, p_ref.sum(axis=1), bands)
        wear_band = _band_power(freqs, p_wear.sum(axis=1), bands)
        usable = (ref_band > _EMPTY_BAND * ref_band.max()) & (wear_band > _EMPTY_BAND * wear_band.max())
        if usable.sum() < 2:
            raise HavError("paired recordings share too little vibration to fit a mounting correction")
        gain = np.sqrt(ref_band[usable] / wear_band[usable])
        return cls(subject, position, tuple(band_centre_hz(bands[usable]).tolist()), tuple(gain.tolist()))

    def gain_at(self, freq_hz: np.ndarray) -> np.ndarray:
        """The gain at some frequencies, interpolated in log-frequency; constant beyond the fitted bands.

        Args:
            freq_hz: Frequencies, Hz.

        Returns:
            G(f), reference over wearable amplitude, same shape as ``freq_hz``.
        """
        f = np.maximum(np.asarray(freq_hz, dtype=float), 1e-3)
        return np.interp(np.log10(f), np.log10(self.band_hz), self.gain)

    def fir(self, fs: float, taps: int = FIR_TAPS) -> np.ndarray:
        """A linear-phase FIR filter whose gain follows G(f) up to fs/2 (frequency sampling, ``firwin2``).

        Args:
            fs: Sampling rate of the signal it will filter, Hz.
            taps: Filter length.

        Returns:
            (taps,) filter coefficients.
        """
        freqs = np.linspace(0.0, fs / 2.0, 1025)
        return scipy.signal.firwin2(taps, freqs, self.gain_at(freqs), fs=fs)

    @property
    def key(self) -> tuple[str, str]:
        """(subject, position): what a correction is looked up by."""
        return (self.subject, self.position)

    def to_json(self) -> str:
        """The correction as JSON.

        Returns:
            A JSON object of subject, position, band_hz and gain.
        """
        return json.dumps({"subject": self.subject, "position": self.position, "band_hz": self.band_hz,
                           "gain": self.gain})

    @classmethod
    def from_json(cls, text: str) -> MountingCorrection:
        """A correction from its JSON (``to_json``'s output).

        Args:
            text: The JSON object.

        Returns:
            The correction.
        """
        data = json.loads(text)
        return cls(data["subject"], data["position"], tuple(data["band_hz"]), tuple(data["gain"]))


def _paired(reference: np.ndarray, wearable: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    ref, wear = np.asarray(reference, dtype=float), np.asarray(wearable, dtype=float)
    if ref.ndim != 2 or ref.shape[1] != 3 or ref.shape != wear.shape:
        raise HavError(f"paired recordings must both be (n, 3), got {ref.shape} and {wear.shape}")
    if not (np.isfinite(ref).all() and np.isfinite(wear).all()):
        raise HavError("paired recordings contain NaN or infinite samples")
    return ref - ref.mean(axis=0), wear - wear.mean(axis=0)


def _band_power(freqs: np.ndarray, psd: np.ndarray, bands: np.ndarray) -> np.ndarray:
    """Power in each one-third-octave band (edges 10^((n -/+ 0.5)/10) Hz)."""
    lo, hi = band_centre_hz(bands - 0.5), band_centre_hz(bands + 0.5)
    return np.array([psd[(freqs >= a) & (freqs < b)].sum() for a, b in zip(lo, hi)])
