"""voxel_means numbers the occupied cubes with a table over the box where the box is small enough, and by sorting
the keys where it is not: the same cubes, in the same order, with the same means bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.localization import cloud


def reference(points: np.ndarray, voxel: float) -> np.ndarray:
    """Each cube's mean, cubes in ascending key order, the points added in their own order (np.add.at)."""
    cells = np.floor(points / voxel).astype(np.int64)
    cells -= cells.min(axis=0)
    size = cells.max(axis=0) + 1
    keys = (cells[:, 0] * size[1] + cells[:, 1]) * size[2] + cells[:, 2]
    unique, inverse = np.unique(keys, return_inverse=True)
    sums = np.zeros((len(unique), 3))
    np.add.at(sums, inverse.reshape(-1), points)
    return sums / np.bincount(inverse.reshape(-1))[:, None]


@pytest.mark.parametrize("dense", [True, False])
def test_cube_means_equal_the_sorted_keys_bit_for_bit(dense, monkeypatch):
    monkeypatch.setattr(cloud, "DENSE_CUBES", 10**9 if dense else 0)
    rng = np.random.default_rng(7)
    points = np.concatenate([rng.normal(0.0, 0.7, (20_000, 3)), rng.uniform(-3.0, 3.0, (500, 3))])
    means = cloud.voxel_means(points, 0.05)
    want = reference(points, 0.05)
    assert means.shape == want.shape and np.array_equal(means, want)
    assert len(means) < len(points)  # cubes were shared


def test_the_table_is_not_built_for_a_huge_box(monkeypatch):
    """Two points 100 km apart at 5 cm: 2e6 x 1 x 1 cubes, over the table's limit; the sort answers."""
    monkeypatch.setattr(cloud, "DENSE_CUBES", 1_000_000)
    built = []
    original = np.bincount
    monkeypatch.setattr(np, "bincount", lambda keys, *a, **k: built.append(k.get("minlength", 0)) or
                        original(keys, *a, **k))
    means = cloud.voxel_means(np.array([[0.0, 0.0, 0.0], [100_000.0, 0.0, 0.0]]), 0.05)
    assert np.array_equal(means, [[0.0, 0.0, 0.0], [100_000.0, 0.0, 0.0]])
    assert max(built) <= 2  # only the sums' bincounts, no table of 2e6 counts


def test_the_range_test_is_numpys_finite_rows_and_lengths():
    """scan_points' compiled filter: numpy's finite rows and ``np.linalg.norm`` lengths in [low, high], bit for
    bit: rows with NaN or inf out, lengths exactly at either bound in (3-4-5 triangles), a hair beyond out."""
    from bim2rdt.registration import kernels

    rng = np.random.default_rng(3)
    points = rng.normal(0.0, 3.0, (50_000, 3))
    points[::97, 1] = np.nan
    points[::89, 2] = np.inf
    edges = np.array([[0.3, 0.4, 0.0], [3.0, 0.0, 4.0], [0.0, 0.0, np.nextafter(5.0, 6.0)], [0.0, 0.29, 0.4]])
    points = np.concatenate([points, edges])
    finite = np.all(np.isfinite(points), axis=1)
    length = np.linalg.norm(np.where(finite[:, None], points, 0.0), axis=1)
    want = finite & (length >= 0.5) & (length <= 5.0)
    got = kernels.in_range(points, 0.5, 5.0)
    assert np.array_equal(got, want) and got[-4:].tolist() == [True, True, False, False]
    assert 0 < want.sum() < len(want) - 1000  # both kinds dropped
