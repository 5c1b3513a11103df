"""Mounting correction: fitted from paired palm/wrist recordings, applied before the weighting."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from bim2rdt.safety import HavError, MountingCorrection, a_hv, weighted_rms
from bim2rdt.sim.vibration import tool_vibration

from hav_helpers import DAY, feed, plan_batches

FS = 5000.0


def wrist_of(palm: np.ndarray) -> np.ndarray:
    """What a wrist sensor sees: the hand damps high frequencies (2nd-order low-pass at 60 Hz)."""
    sos = scipy.signal.butter(2, 60.0, fs=FS, output="sos")
    return scipy.signal.sosfilt(sos, palm - palm.mean(axis=0), axis=0).astype(np.float32)


def total(signal: np.ndarray) -> float:
    return a_hv(*[weighted_rms(signal[:, i], FS) for i in range(3)])


def test_a_fitted_correction_recovers_the_palm_exposure_from_a_new_wrist_recording():
    palm = tool_vibration("hammer_drill", 30, FS, 10.0, seed=1)
    correction = MountingCorrection.fit(palm, wrist_of(palm), FS, "w-1", "wrist")
    assert correction.gain_at(np.array([10.0]))[0] == pytest.approx(1.0, abs=0.05)  # little damping low down
    assert correction.gain_at(np.array([500.0]))[0] > 20.0  # a lot high up
    new_palm = tool_vibration("hammer_drill", 20, FS, 12.0, seed=7)
    wrist = wrist_of(new_palm)
    freqs = np.fft.rfftfreq(wrist.shape[0], 1 / FS)
    corrected = np.fft.irfft(np.fft.rfft(wrist, axis=0) * correction.gain_at(freqs)[:, None], wrist.shape[0], axis=0)
    assert total(wrist) < 0.9 * total(new_palm)
    assert total(corrected) == pytest.approx(total(new_palm), rel=0.05)


def test_the_monitor_applies_the_correction_and_labels_the_figures_estimates(make_monitor, clock):
    palm = tool_vibration("grinder", 30, FS, 5.0, seed=2)
    monitor, sink = make_monitor()
    subject = monitor.start_session("band-1", "kim", "grinder", position="wrist")
    monitor.add_correction(MountingCorrection.fit(palm, wrist_of(palm), FS, subject, "wrist"))
    items = plan_batches("band-1", [("idle", 3), ("grinder", 30), ("idle", 5)], a_hv={"grinder": 5.0})
    wrist_items = [b.__class__(b.device, b.seq, b.device_time, b.fs, wrist_of(b.xyz) + [0, 0, 9.81], b.full_scale)
                   for b in items]
    feed(monitor, wrist_items, clock)
    ended = next(e for e in sink.events if e.kind == "hav.activity_ended")
    assert ended.data["a_hv"] == pytest.approx(5.0, rel=0.1)
    assert ended.data["estimate"] is True and ended.data["corrected"] is True
    assert monitor.queries.day(subject, DAY).a8 > 0


def test_a_correction_survives_a_round_trip_through_json():
    palm = tool_vibration("grinder", 10, FS, seed=3)
    fit = MountingCorrection.fit(palm, wrist_of(palm), FS, "w-2", "forearm")
    assert MountingCorrection.from_json(fit.to_json()) == fit


def test_recordings_of_different_shapes_are_refused():
    with pytest.raises(HavError, match="paired recordings"):
        MountingCorrection.fit(np.zeros((100, 3)), np.zeros((90, 3)), FS, "w", "wrist")
