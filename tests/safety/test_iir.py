"""The compiled weighting pass (safety.iir.sosfilt_rows) is scipy's sosfilt bit for bit, on float32 and float64
rows, with carried state, and leaves its inputs alone."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from bim2rdt.safety.filters import design_weighting
from bim2rdt.safety.iir import sosfilt_rows


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_rows_filtered_equal_sosfilt_exactly_with_carried_state(dtype):
    rng = np.random.default_rng(7)
    sos = design_weighting(5000.0).sos
    x = (rng.normal(0.0, 40.0, (9, 3000)) + 9.81).astype(dtype)
    zi = rng.normal(0.0, 3.0, (sos.shape[0], 9, 2))
    x_before, zi_before = x.copy(), zi.copy()
    expected, expected_zf = scipy.signal.sosfilt(sos, x, axis=-1, zi=zi)
    out, zf = sosfilt_rows(sos, x, zi)
    assert out.dtype == np.float64 and out.shape == x.shape and zf.shape == zi.shape
    assert np.array_equal(out, expected) and np.array_equal(zf, expected_zf)  # every bit
    assert np.array_equal(x, x_before) and np.array_equal(zi, zi_before)
    half, zf_half = sosfilt_rows(sos, x[:, :1700].copy(), zi)  # a stream cut in two runs: the same result
    rest, zf_rest = sosfilt_rows(sos, x[:, 1700:].copy(), zf_half)
    assert np.array_equal(np.concatenate([half, rest], axis=1), expected) and np.array_equal(zf_rest, expected_zf)


def test_another_rate_and_section_count_also_match():
    sos = design_weighting(1600.0).sos
    x = np.random.default_rng(8).normal(0.0, 10.0, (3, 800)).astype(np.float32)
    zi = np.zeros((sos.shape[0], 3, 2))
    assert np.array_equal(sosfilt_rows(sos, x, zi)[0], scipy.signal.sosfilt(sos, x, axis=-1, zi=zi)[0])
