"""Model sampling (Algorithm 1's SampleModelWithNormals): on the surface, unit outward normals, no resting face."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from bim2rdt.registration import RegistrationError, sample_model
from bim2rdt.sim.meshes import wooden_crate


def test_samples_lie_on_the_box_with_its_face_normals_and_none_on_the_face_it_stands_on():
    box = trimesh.creation.box(extents=(1.0, 0.5, 0.4), transform=trimesh.transformations.translation_matrix(
        (0.0, 0.0, 0.2)))
    points, normals = sample_model(box, 500, seed=3)
    assert points.shape == normals.shape == (500, 3)
    on_face = np.isclose(np.abs(points), (0.5, 0.25, 0.0), atol=1e-9) | np.isclose(points, (0, 0, 0.4), atol=1e-9)
    assert on_face.any(axis=1).all()
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0)
    assert np.all(np.einsum("ni,ni->n", normals, points - (0.0, 0.0, 0.2)) > 0.0)  # outward
    assert not np.any(normals[:, 2] < -0.9)
    _, with_base = sample_model(box, 500, seed=3, drop_resting_face=False)
    assert np.any(with_base[:, 2] < -0.9)


@pytest.mark.parametrize("count", [0, 5, -1])
def test_too_few_samples_raise_a_registration_error(count):
    with pytest.raises(RegistrationError, match=f"count must be >= 6, got {count}"):
        sample_model(wooden_crate(), count)


def test_an_empty_mesh_raises_a_registration_error():
    with pytest.raises(RegistrationError, match="empty mesh"):
        sample_model(trimesh.Trimesh(), 100)
