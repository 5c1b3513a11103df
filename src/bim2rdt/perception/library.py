"""The BIM's site-object families as registration models: one body mesh per family, its size, and surface
samples, built once per model and shared by the detectors and the registration step.

A family's body mesh is its first element's tessellated body brought back to that element's own frame (the
inverse of its placement), so it stands upright along +z as SG-ICP expects. Elements of one family share
their geometry in the authoring tools this is built for (a family *is* a shared type).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from bim2rdt.bim import BimElement, BimModel
from bim2rdt.perception.structure import movable_elements
from bim2rdt.registration import sample_model


def element_body_mesh(model: BimModel, global_id: str) -> trimesh.Trimesh:
    """An element's tessellated body in its own frame (world mesh mapped through the inverse placement).

    Args:
        model: The BIM, loaded with geometry.
        global_id: The element's GlobalId.

    Returns:
        Its mesh, body frame, metres.
    """
    vertices_world, faces = model.mesh(global_id)
    T_model_world = np.linalg.inv(model.element(global_id).placement)
    vertices_body = vertices_world @ T_model_world[:3, :3].T + T_model_world[:3, 3]
    return trimesh.Trimesh(vertices_body, faces, process=False)


@dataclass
class FamilyModel:
    """One family's body mesh (metres, upright +z) and its surface samples, drawn lazily and cached."""

    family: str
    mesh: trimesh.Trimesh
    _samples: dict[int, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict, repr=False)
    _trees: dict[int, cKDTree] = field(default_factory=dict, repr=False)

    @cached_property
    def extents(self) -> np.ndarray:
        """(3,) body-frame bounding-box size: length along x, width along y, height along z (m)."""
        return np.asarray(self.mesh.extents, dtype=float)

    @property
    def height(self) -> float:
        return float(self.extents[2])

    @property
    def footprint(self) -> float:
        """The plan diagonal (m): no view of the object spans more than this horizontally."""
        return float(np.hypot(*self.extents[:2]))

    def samples(self, count: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """``count`` surface samples and normals (body frame) for registration."""
        if count not in self._samples:
            self._samples[count] = sample_model(self.mesh, count, seed=seed)
        return self._samples[count]

    def tree(self, count: int) -> cKDTree:
        """A k-d tree over :meth:`samples` (``count`` of them), for nearest-sample queries."""
        if count not in self._trees:
            self._trees[count] = cKDTree(self.samples(count)[0])
        return self._trees[count]


class ModelLibrary:
    """The model's movable elements and one :class:`FamilyModel` per family among them."""

    def __init__(self, model: BimModel) -> None:
        self.model = model
        self.elements: list[BimElement] = movable_elements(model)
        self.families: dict[str, FamilyModel] = {}
        for el in self.elements:
            if el.family not in self.families:
                self.families[el.family] = FamilyModel(el.family, element_body_mesh(model, el.global_id))

    def near(self, xy: np.ndarray, radius: float) -> list[BimElement]:
        """Movable elements whose placement lies within ``radius`` m of ``xy`` in plan, nearest first."""
        distances = [float(np.linalg.norm(el.placement[:2, 3] - xy[:2])) for el in self.elements]
        order = np.argsort(distances, kind="stable")
        return [self.elements[i] for i in order if distances[i] <= radius]

    def body_mesh(self, global_id: str) -> trimesh.Trimesh:
        return element_body_mesh(self.model, global_id)


_LIBRARIES: dict[tuple[int, str], ModelLibrary] = {}


def library_for(model: BimModel) -> ModelLibrary:
    """The :class:`ModelLibrary` of ``model``, built on first use and kept for the few models a process uses."""
    key = (id(model), model.digest)
    if key not in _LIBRARIES or _LIBRARIES[key].model is not model:
        if len(_LIBRARIES) >= 4:
            _LIBRARIES.pop(next(iter(_LIBRARIES)))
        _LIBRARIES[key] = ModelLibrary(model)
    return _LIBRARIES[key]
