"""The compiled weighting pass (safety.iir) is scipy's sosfilt bit for bit, on float32 and float64 rows, with
carried state, leaves its inputs alone, and takes numpy's block extremes on its way."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from bim2rdt.safety.filters import design_weighting
from bim2rdt.safety.iir import sosfilt_rows, weigh_rows


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


@pytest.mark.parametrize("starts", [np.array([0, 2500]), np.array([0, 1700, 3100])])
def test_the_pass_takes_numpys_block_extremes_on_its_way_nan_included(starts):
    sos = design_weighting(5000.0).sos
    x = np.random.default_rng(9).normal(0.0, 30.0, (6, 5000)).astype(np.float32)
    x[1, 10], x[4, 4999], x[5, 0] = np.nan, np.nan, np.nan  # inside a block, at the last and at the first sample
    zi = np.zeros((sos.shape[0], 6, 2))
    out, zf, (top, bottom) = weigh_rows(sos, x, zi, starts)
    reference = sosfilt_rows(sos, x, zi)
    assert np.array_equal(out, reference[0], equal_nan=True) and np.array_equal(zf, reference[1], equal_nan=True)
    assert top.dtype == bottom.dtype == np.float32
    assert np.array_equal(top, np.maximum.reduceat(x, starts, axis=1), equal_nan=True)
    assert np.array_equal(bottom, np.minimum.reduceat(x, starts, axis=1), equal_nan=True)
    assert np.isnan(top[1, 0]) and not np.isnan(top[1, -1]) and np.isnan(bottom[4, -1]) and np.isnan(top[5, 0])


def test_a_chunk_weighed_again_settles_its_streams_on_the_replaced_first_sample():
    """A stream with no filter state yet (restored without one) whose first sample is NaN: the chunk is weighed
    again after the replacement, and the filter starts from the replaced sample, as if it had come that way."""
    from bim2rdt.bus import AccelBatch
    from bim2rdt.safety.config import ArtefactLimits
    from bim2rdt.safety.weighing import FilterState, Piece, weigh_round

    x = (np.random.default_rng(10).normal(0.0, 20.0, (2500, 3)) + 9.81).astype(np.float32)
    bad = x.copy()
    bad[0, 1] = np.nan
    row = np.ascontiguousarray(bad[:, 1])
    fixed = x.copy()
    fixed[0, 1] = row[1:].mean()  # what replace_bad_samples puts there: the row's mean of its good samples
    pieces = [Piece(FilterState(), [AccelBatch("w", 0, 1.7e9, 5000.0, samples)], False) for samples in (bad, fixed)]
    blocks = weigh_round(pieces, ArtefactLimits())
    assert blocks[0].flags[0] and not blocks[1].flags[0]  # the NaN block is flagged, the fixed one is not
    assert np.isfinite(pieces[0].state.zi).all() and np.array_equal(pieces[0].state.zi, pieces[1].state.zi)
    assert blocks[0].energy == blocks[1].energy


@pytest.mark.parametrize("sections", [1, 2, 3, 4])
def test_every_section_count_is_sosfilt_bit_for_bit_registers_or_not(sections):
    """Two and three sections (every Wh filter) run with the states in registers, other counts through the generic
    kernel: each is sosfilt exactly, with carried state, its extremes too, the generic and the register kernels
    alike (the register kernels' operations are scipy's, in scipy's order)."""
    rng = np.random.default_rng(11 + sections)
    sos = np.concatenate([design_weighting(5000.0).sos, design_weighting(1600.0).sos])[:sections]
    x = (rng.normal(0.0, 40.0, (6, 2001)) + 9.81).astype(np.float32)
    zi = rng.normal(0.0, 3.0, (sections, 6, 2))
    expected, expected_zf = scipy.signal.sosfilt(sos, x, axis=-1, zi=zi)
    starts = np.array([0, 900])
    out, zf, (top, bottom) = weigh_rows(sos, x, zi, starts)
    assert np.array_equal(out, expected) and np.array_equal(zf, expected_zf)
    assert np.array_equal(top, np.maximum.reduceat(x, starts, axis=1))
    assert np.array_equal(bottom, np.minimum.reduceat(x, starts, axis=1))
    out, zf = sosfilt_rows(sos, x.astype(np.float64), zi)
    assert np.array_equal(out, expected) and np.array_equal(zf, expected_zf)


def test_rows_without_samples_keep_their_state():
    sos = design_weighting(5000.0).sos
    zi = np.random.default_rng(12).normal(0.0, 3.0, (sos.shape[0], 3, 2))
    out, zf = sosfilt_rows(sos, np.zeros((3, 0), np.float32), zi)
    assert out.shape == (3, 0) and np.array_equal(zf, zi)
