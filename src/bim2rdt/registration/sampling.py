"""Algorithm 1's SampleModelWithNormals: surface points of a BIM element's mesh, with their face normals."""

from __future__ import annotations

import numpy as np
import trimesh

from bim2rdt.registration.errors import RegistrationError


def sample_model(mesh: trimesh.Trimesh, count: int = 2000, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``count`` area-uniform samples on the mesh surface (body frame, m) and their unit outward normals."""
    if mesh.is_empty or mesh.area <= 0.0:
        raise RegistrationError("cannot sample a model from an empty mesh")
    points, face_index = trimesh.sample.sample_surface(mesh, count, seed=seed)
    return np.asarray(points, dtype=np.float64), np.asarray(mesh.face_normals[face_index], dtype=np.float64)
