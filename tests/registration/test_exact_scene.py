"""A scene that lies exactly on the model's own samples has no residual spread: registration still returns the
pose, with a finite covariance, instead of dividing by a zero spread."""

from __future__ import annotations

import numpy as np
import trimesh

from bim2rdt.registration import register


def test_a_scene_exactly_on_the_models_samples_registers_with_a_finite_covariance():
    box = trimesh.creation.box((1.0, 0.5, 0.8))
    points, faces = trimesh.sample.sample_surface(box, 3000, seed=0)
    normals = box.face_normals[faces]
    shift = np.array([0.05, 0.02, 0.0])
    visible = points[points[:, 0] > -0.2]  # one side of the box is unseen, as from a sensor
    result = register(points, normals, visible + shift, upright_bias=1.0)
    assert np.allclose(result.pose[:3, 3], shift, atol=1e-3)
    assert np.all(np.isfinite(result.uncertainty.covariance))
