"""Algorithm 1's SampleModelWithNormals: surface points of a BIM element's mesh, with their face normals."""

from __future__ import annotations

import numpy as np
import trimesh

from bim2rdt import exact
from bim2rdt.registration.errors import RegistrationError
from bim2rdt.registration.validation import MIN_SCENE_POINTS

RESTING_FACE_TOLERANCE = 0.01
"""Samples this close (m) to the model's lowest point and facing down count as the resting face."""


def sample_model(mesh: trimesh.Trimesh, count: int = 2000, seed: int = 0,
                 drop_resting_face: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """``count`` area-uniform samples on the mesh surface (body frame, m) and their unit outward normals.

    With ``drop_resting_face`` the face an upright object stands on (facing down, at its lowest z) is left out:
    no camera sees it, and its samples would fit the ground around the object perfectly at any yaw and any
    position in the plane, pulling a flat object (a pallet) off its true pose.

    Args:
        mesh: The element's mesh in its body frame, metres, upright along +z.
        count: Number of samples.
        seed: Seed of the sampler (the same seed gives the same samples).
        drop_resting_face: Leave out the downward face at the mesh's lowest z.

    Returns:
        ((count,3) points in the body frame, metres; (count,3) unit outward face normals).

    Raises:
        RegistrationError: ``count`` is below what :func:`register` needs, or the mesh is empty.
    """
    if count < MIN_SCENE_POINTS:
        raise RegistrationError(f"count must be >= {MIN_SCENE_POINTS}, got {count}: register needs that many")
    if mesh.is_empty or mesh.area <= 0.0:
        raise RegistrationError("cannot sample a model from an empty mesh")
    keep = np.ones(len(mesh.faces), dtype=bool)
    if drop_resting_face:
        lowest = mesh.triangles[:, :, 2].max(axis=1) <= mesh.bounds[0, 2] + RESTING_FACE_TOLERANCE
        keep &= ~(lowest & (mesh.face_normals[:, 2] < -0.9))
    visible = mesh.submesh([np.flatnonzero(keep)], append=True) if not keep.all() else mesh
    points, face_index = trimesh.sample.sample_surface(visible, count, seed=seed)
    return np.asarray(points, dtype=np.float64), unit_face_normals(visible)[face_index]


def unit_face_normals(mesh: trimesh.Trimesh) -> np.ndarray:
    """(F, 3) unit normals of the mesh's faces (zero for a degenerate one), bit-identical on any machine:
    trimesh's ``face_normals`` normalise through a BLAS product, whose last bit follows the CPU."""
    corners = np.asarray(mesh.vertices, dtype=np.float64)[mesh.faces]
    crosses = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    lengths = exact.norm(crosses)[:, None]
    return np.divide(crosses, lengths, out=np.zeros_like(crosses), where=lengths > 0)
