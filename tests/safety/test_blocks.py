"""Per-block statistics as BLAS dot products (blocks.block_stats) equal float64 reference sums, and bad samples
still show."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.safety.blocks import block_stats, block_sums, has_bad_samples


def _reference(raw: np.ndarray, starts: np.ndarray):
    wide = raw.astype(np.float64)
    edges = list(starts) + [raw.shape[1]]
    cut = [wide[:, a:b] for a, b in zip(edges[:-1], edges[1:])]
    return (np.stack([c.sum(axis=1) for c in cut], axis=1), np.stack([(c * c).sum(axis=1) for c in cut], axis=1),
            np.stack([c.max(axis=1) for c in cut], axis=1), np.stack([c.min(axis=1) for c in cut], axis=1))


@pytest.mark.parametrize("starts", [np.array([0, 2500]), np.array([0, 1700, 3100])])  # equal blocks, and not
def test_block_stats_match_float64_sums_of_the_same_samples(starts):
    raw = (np.random.default_rng(3).normal(0.0, 30.0, (12, 5000)) + 9.81).astype(np.float32)
    stats = block_stats(raw, starts)
    sums, squares, top, bottom = _reference(raw, starts)
    assert stats.sums.shape == stats.squares.shape == (12, starts.size)
    np.testing.assert_allclose(stats.sums, sums, rtol=1e-5, atol=0.05)  # float32 sums of 2500 values near 10
    np.testing.assert_allclose(stats.squares, squares, rtol=1e-5)
    assert np.array_equal(stats.extremes[0], top) and np.array_equal(stats.extremes[1], bottom)


def test_block_energies_of_float64_samples_are_exact_to_rounding():
    weighted = np.random.default_rng(4).normal(0.0, 5.0, (6, 5000))
    energy = block_sums(weighted, np.array([0, 2500]), square=True)
    np.testing.assert_allclose(energy, _reference(weighted, np.array([0, 2500]))[1], rtol=1e-12)


@pytest.mark.parametrize("bad", [np.nan, np.inf, 1e30])
def test_a_bad_sample_still_shows_in_the_stats_without_a_warning(bad):
    raw = np.full((3, 5000), 9.81, np.float32)
    raw[1, 4000] = bad
    with np.errstate(all="raise"):
        stats = block_stats(raw, np.array([0, 2500]))
    assert has_bad_samples(stats.sums, stats.extremes, np.array([1000.0]))
    clean = block_stats(np.full((3, 5000), 9.81, np.float32), np.array([0, 2500]))
    assert not has_bad_samples(clean.sums, clean.extremes, np.array([1000.0]))
