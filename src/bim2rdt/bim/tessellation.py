"""Tessellating an IFC file into per-element triangle meshes in world metres (``ifcopenshell.geom``).

The iterator is run single-threaded (on two cores ``num_threads=2`` measured slower) and read with ``get()``
before ``next()`` (the other order skips the first shape, IfcOpenShell bug #2162). ``ifcopenshell.geom``
always returns metres, whatever the file's unit. Elements whose body the iterator does not return are retried
one by one with ``create_shape`` to get the reason; what still fails is reported, never silently dropped.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

import ifcopenshell
import ifcopenshell.geom
import numpy as np

from bim2rdt.bim.records import GeometryFailure

Progress = Callable[[int, int], None]
EXCLUDED = ["IfcOpeningElement"]
"""Openings are subtracted from their hosts by the kernel; their own solids are voids, not site objects."""
BODY_IDENTIFIERS = ("Body", "Facetation", None)


@dataclass
class MeshSet:
    """Meshes of many elements packed into two arrays: element i owns ``vertices[v_off[i]:v_off[i+1]]`` (world
    metres) and ``faces[f_off[i]:f_off[i+1]]`` (indices local to its own vertices)."""

    ids: list[str]
    vertices: np.ndarray
    faces: np.ndarray
    vertex_offsets: np.ndarray
    face_offsets: np.ndarray
    _index: dict[str, int] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        self._index = {gid: i for i, gid in enumerate(self.ids)}

    def __contains__(self, global_id: str) -> bool:
        return global_id in self._index

    def get(self, global_id: str) -> tuple[np.ndarray, np.ndarray]:
        """(vertices (N,3) float64 world metres, faces (M,3) int32) of one element; KeyError if absent."""
        i = self._index[global_id]
        return (self.vertices[self.vertex_offsets[i]:self.vertex_offsets[i + 1]],
                self.faces[self.face_offsets[i]:self.face_offsets[i + 1]])

    @classmethod
    def pack(cls, meshes: dict[str, tuple[np.ndarray, np.ndarray]]) -> MeshSet:
        """Pack {global_id: (vertices, faces)} into one MeshSet."""
        ids = list(meshes)
        verts = [meshes[g][0].reshape(-1, 3) for g in ids]
        faces = [meshes[g][1].reshape(-1, 3) for g in ids]
        v_off = np.concatenate([[0], np.cumsum([len(v) for v in verts])]).astype(np.int64)
        f_off = np.concatenate([[0], np.cumsum([len(f) for f in faces])]).astype(np.int64)
        return cls(ids, np.concatenate(verts) if verts else np.zeros((0, 3)),
                   np.concatenate(faces).astype(np.int32) if faces else np.zeros((0, 3), np.int32), v_off, f_off)


def geometry_settings() -> ifcopenshell.geom.settings:
    """World coordinates (metres), triangulated: what ray casting, sampling and bounding boxes need."""
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    return settings


def tessellate(ifc: ifcopenshell.file, expected_ids: Iterable[str],
               progress: Progress | None = None) -> tuple[MeshSet, list[GeometryFailure]]:
    """Meshes of every element with a body, plus a failure record for each expected element without one."""
    meshes = iterate_meshes(ifc, progress)
    failures = []
    for global_id in expected_ids:
        if global_id in meshes:
            continue
        mesh, failure = _retry_one(ifc, ifc.by_guid(global_id))
        if mesh is not None:
            meshes[global_id] = mesh
        elif failure is not None:
            failures.append(failure)
    return MeshSet.pack(meshes), failures


def iterate_meshes(ifc: ifcopenshell.file, progress: Progress | None = None) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """One pass of the geometry iterator: {GlobalId: (vertices (N,3), faces (M,3))} in world metres."""
    iterator = ifcopenshell.geom.iterator(geometry_settings(), ifc, num_threads=1, exclude=EXCLUDED)
    meshes: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    if not iterator.initialize():
        return meshes
    while True:
        shape = iterator.get()
        geometry = shape.geometry
        meshes[shape.guid] = (np.frombuffer(geometry.verts_buffer, dtype=np.float64).reshape(-1, 3),
                              np.frombuffer(geometry.faces_buffer, dtype=np.int32).reshape(-1, 3))
        if progress is not None:
            progress(iterator.progress(), 100)
        if not iterator.next():
            break
    return meshes


def has_body(product: ifcopenshell.entity_instance) -> bool:
    """True when the product carries a 3-D body representation the iterator should tessellate."""
    shape = getattr(product, "Representation", None)
    if shape is None:
        return False
    return any(rep.RepresentationIdentifier in BODY_IDENTIFIERS
               and getattr(rep.ContextOfItems, "ContextType", "Model") in ("Model", None)
               for rep in shape.Representations)


def _retry_one(ifc: ifcopenshell.file, product: ifcopenshell.entity_instance):
    try:
        shape = ifcopenshell.geom.create_shape(geometry_settings(), product)
    except Exception as error:  # the kernel raises RuntimeError or its own types; the reason is what we keep
        return None, GeometryFailure(product.GlobalId, product.is_a(), _one_line(error))
    verts = np.asarray(shape.geometry.verts, dtype=float).reshape(-1, 3)
    faces = np.asarray(shape.geometry.faces, dtype=np.int32).reshape(-1, 3)
    if len(faces) == 0:
        return None, GeometryFailure(product.GlobalId, product.is_a(), "the body tessellates to no triangles")
    return (verts, faces), None


def _one_line(error: Exception) -> str:
    text = " ".join(str(error).split()) or type(error).__name__
    return text[:200]
