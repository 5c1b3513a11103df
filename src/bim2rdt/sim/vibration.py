"""Simulated power-tool vibration at the hand, as a wearable would record it (m/s^2, x/y/z, gravity on z).

Each tool is a line spectrum (the blow or rotation frequency and its harmonics, lines broadened by speed
jitter) over a broadband floor, with magnitudes from the UK HSE's typical ranges: rotary hammer drill ~10
m/s^2 (blows ~45 Hz), angle grinder ~5 m/s^2 (disc imbalance ~160 Hz), road breaker ~15 m/s^2 (blows ~25 Hz).
A tool's signal is one seamlessly periodic 8 s loop (inverse FFT), tiled and slowly amplitude-modulated,
scaled so its Wh-weighted vibration total value a_hv is the requested one (exact over whole loops).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from bim2rdt.bus.payloads import AccelBatch
from bim2rdt.safety.weighting import weighting_power

GRAVITY = 9.80665
LOOP_S = 8.0
MODULATION_HZ = 0.1
"""A tool's slow amplitude modulation (the operator's grip and feed force), Hz ..."""
MODULATION_DEPTH = 0.05
"""... and its depth: +-5 %."""
WEARABLE_RANGE = 200 * GRAVITY
"""Sensor range, m/s^2: a +-200 g MEMS accelerometer (percussive tools peak at hundreds of m/s^2 unweighted)."""


@dataclass(frozen=True)
class ToolProfile:
    """A tool's vibration: ``fundamental_hz`` with ``harmonics`` lines decaying as k^-``decay``, a noise
    floor carrying ``noise_share`` of the power, per-axis amplitude shares, a typical a_hv in m/s^2."""

    name: str
    fundamental_hz: float
    harmonics: int
    decay: float
    noise_share: float
    axis_share: tuple[float, float, float]
    a_hv: float


TOOLS = {
    "hammer_drill": ToolProfile("hammer drill", 45.0, 20, 0.7, 0.25, (1.0, 0.6, 0.5), 10.0),
    "grinder": ToolProfile("angle grinder", 160.0, 6, 1.2, 0.35, (0.7, 1.0, 0.6), 5.0),
    "breaker": ToolProfile("road breaker", 25.0, 30, 0.6, 0.2, (1.0, 0.5, 0.7), 15.0),
    "idle": ToolProfile("handling, no tool", 2.0, 3, 1.0, 0.9, (1.0, 1.0, 1.0), 0.1),
}


class ToolSignal:
    """``seconds`` of ``tool`` at ``fs`` Hz with weighted a_hv = ``a_hv``, sampled piece by piece
    (:meth:`samples`), so a long shift is never held in memory: the loop is tiled and modulated on demand."""

    def __init__(self, tool: str, seconds: float, fs: float, a_hv: float | None = None, seed: int = 0):
        profile = TOOLS[tool]
        rng = np.random.default_rng(seed)
        self.loop = _loop(profile, fs, rng).astype(np.float32)
        self.fs, self.n = fs, int(round(seconds * fs))
        self.target = profile.a_hv if a_hv is None else a_hv
        self._phase = rng.uniform(0, 2 * np.pi)
        self._omega = 2 * np.pi * MODULATION_HZ / fs
        self._norm = np.sqrt(_mean_square_modulation(self.n, self._omega, self._phase))
        self._rotations: dict[int, np.ndarray] = {}

    def samples(self, start: int = 0, stop: int | None = None) -> np.ndarray:
        """(stop - start, 3) float32 samples ``start``..``stop`` of the signal, gravity on z."""
        stop = self.n if stop is None else min(stop, self.n)
        modulation = 1.0 + MODULATION_DEPTH * self._sine(start, stop - start)
        signal = self._tiled(start, stop) * (self.target * modulation / self._norm).astype(np.float32)[:, None]
        signal[:, 2] += np.float32(GRAVITY)
        return signal

    def _sine(self, start: int, count: int) -> np.ndarray:
        """sin(omega k + phase) for k = start..start+count: one complex rotation of a cached table of
        exp(i omega j), j < count, instead of ``count`` sines (the modulation is 0.1 Hz: smooth)."""
        table = self._rotations.get(count)
        if table is None:
            table = self._rotations[count] = np.exp(1j * self._omega * np.arange(count))
        return (np.exp(1j * (self._omega * start + self._phase)) * table).imag

    def _tiled(self, start: int, stop: int) -> np.ndarray:
        """Samples ``start``..``stop`` of the loop repeated end to end (slices, no index arrays)."""
        size = self.loop.shape[0]
        first = start % size
        if first + stop - start <= size:
            return self.loop[first:first + stop - start]
        return np.take(self.loop, np.arange(start, stop) % size, axis=0)


def tool_vibration(tool: str, seconds: float, fs: float, a_hv: float | None = None,
                   seed: int = 0) -> np.ndarray:
    """(n, 3) float32 acceleration of ``seconds`` of ``tool`` at ``fs`` Hz, weighted a_hv = ``a_hv``."""
    return ToolSignal(tool, seconds, fs, a_hv, seed).samples()


def _mean_square_modulation(n: int, omega: float, phase: float) -> float:
    """Mean over k < n of (1 + d sin(omega k + phase))^2, in closed form (sums of sines in arithmetic
    progression), so the a_hv scaling does not need the whole signal at once."""
    if n == 0:
        return 1.0
    sin_sum = math.sin(n * omega / 2) * math.sin(phase + (n - 1) * omega / 2) / math.sin(omega / 2)
    cos2_sum = math.sin(n * omega) * math.cos(2 * phase + (n - 1) * omega) / math.sin(omega)
    square_sum = n / 2 - cos2_sum / 2
    return (n + 2 * MODULATION_DEPTH * sin_sum + MODULATION_DEPTH**2 * square_sum) / n


def _loop(profile: ToolProfile, fs: float, rng: np.random.Generator) -> np.ndarray:
    """One periodic loop with weighted a_hv = 1 m/s^2 (so scaling sets the a_hv exactly)."""
    n = int(LOOP_S * fs)
    freqs = np.fft.rfftfreq(n, 1.0 / fs)
    spectra = np.stack([_axis_spectrum(profile, freqs, rng) * share for share in profile.axis_share])
    weighted_energy = (np.abs(spectra) ** 2 * weighting_power(n, fs)).sum()
    loop = np.fft.irfft(spectra, n, axis=-1).T
    # Parseval (one-sided, interior bins count twice): mean of the weighted square per sample
    return loop / np.sqrt(2.0 * weighted_energy / n**2)


def _axis_spectrum(profile: ToolProfile, freqs: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    amplitude = np.zeros_like(freqs)
    for k in range(1, profile.harmonics + 1):
        centre = profile.fundamental_hz * k
        width = 0.015 * centre + 0.3
        amplitude += k**-profile.decay * np.exp(-0.5 * ((freqs - centre) / width) ** 2)
    floor = 1.0 / (1.0 + (freqs / 400.0) ** 2) * (freqs > 2.0)
    line_power, floor_power = (amplitude**2).sum(), (floor**2).sum()
    floor *= np.sqrt(profile.noise_share / (1 - profile.noise_share) * line_power / floor_power)
    phases = rng.uniform(-np.pi, np.pi, freqs.size)
    return (amplitude + floor * rng.standard_normal(freqs.size)) * np.exp(1j * phases)


def session_signal(plan: Sequence[tuple[str, float]], fs: float, seed: int = 0,
                   a_hv: dict[str, float] | None = None) -> np.ndarray:
    """(n, 3) signal of a work plan: consecutive (tool, seconds) pieces, 'idle' for pauses."""
    pieces = [tool_vibration(tool, seconds, fs, (a_hv or {}).get(tool), seed + i) for i, (tool, seconds)
              in enumerate(plan)]
    return np.concatenate(pieces)


def batches(device: str, signal: np.ndarray | ToolSignal, fs: float, start_time: float, batch_s: float = 0.5,
            first_seq: int = 0, full_scale: float | None = WEARABLE_RANGE) -> Iterator[AccelBatch]:
    """Cut ``signal`` ((n, 3) samples, or a :class:`ToolSignal` sampled as it goes) into the batches a wearable
    would publish (seq, device time of first sample)."""
    step = max(1, int(round(batch_s * fs)))
    n = signal.n if isinstance(signal, ToolSignal) else signal.shape[0]
    for i, start in enumerate(range(0, n, step)):
        samples = signal.samples(start, start + step) if isinstance(signal, ToolSignal) else signal[start:start + step]
        yield AccelBatch(device, first_seq + i, start_time + start / fs, fs, samples, full_scale)
