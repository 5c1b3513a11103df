"""The streaming Wh IIR: fitted to the exact response, within ISO 8041-1 at every band for fs >= 5 kHz."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from bim2rdt.safety import covered_band, wh_weighting_factor
from bim2rdt.safety.filters import design_weighting
from bim2rdt.safety.weighting import band_centre_hz

from test_weighting import iso8041_tolerance


@pytest.mark.parametrize("fs", [5000.0, 10000.0])
def test_sines_at_every_band_centre_read_within_tolerance_through_the_streaming_filter(fs):
    design = design_weighting(fs)
    t = np.arange(int(6 * fs)) / fs
    for n in range(9, 31):
        freq = band_centre_hz(n)
        sine = np.sqrt(2) * np.sin(2 * np.pi * freq * t) + 9.81
        out = scipy.signal.sosfilt(design.sos, sine, zi=design.settled_state(sine[:1])[:, 0, :])[0]
        ratio = np.sqrt(np.mean(out[int(fs):] ** 2)) / wh_weighting_factor(freq)  # after 1 s of settling
        low, high = iso8041_tolerance(freq)
        assert low <= ratio <= high, (n, ratio)
        assert ratio == pytest.approx(1.0, abs=0.01)  # a finite sine record; the design itself is below:
    assert design.max_band_error < 0.005


def test_the_fit_is_stable():
    for fs in (800.0, 5000.0, 10000.0):
        poles = np.concatenate([np.roots(section[3:]) for section in design_weighting(fs).sos])
        assert np.all(np.abs(poles) < 1.0)


def test_an_800_hz_sensor_follows_wh_over_the_bands_it_covers():
    design = design_weighting(800.0)
    bands = band_centre_hz(np.arange(9, 26))
    assert bands[-1] == pytest.approx(covered_band(800.0).high_hz)
    _, response = scipy.signal.sosfreqz(design.sos, bands, fs=800.0)
    np.testing.assert_allclose(np.abs(response), wh_weighting_factor(bands), rtol=0.05)
