"""What the twin knows about objects on site, as footprints: where things really are, not where the BIM put them.

The twin's state (``DigitalTwin.state()``: {global_id: state}) is read duck-typed, so any record of the same
shape works (a mission's observations, a test's stand-ins). Per entry:

- ``pose``: 4x4 T_world_model in metres, or None when the place is unknown;
- ``status`` (optional): an ``ElementStatus`` or its value; ``missing`` clears the element's BIM footprint,
  ``not observed`` (or no pose) leaves the BIM's;
- ``global_id`` (optional): the element; else the mapping's key when it is a BIM GlobalId;
- ``mesh`` (needed only for objects the BIM lacks): a ``trimesh.Trimesh`` or ``(vertices, faces)`` in the body
  frame. A BIM element's own mesh is moved to the pose.
- ``family`` or ``name`` (optional): how messages name a new object.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.planning.errors import PlanningError
from bim2rdt.planning.frame import GridFrame
from bim2rdt.planning.raster import Footprint, mesh_cells
from bim2rdt.twin import ElementStatus

_KEEP_BIM = (ElementStatus.NOT_OBSERVED.value,)
_CLEAR = (ElementStatus.MISSING.value,)


@dataclass(frozen=True)
class ObservedLayer:
    """BIM elements whose footprint the twin overrides (moved or missing), and observed objects' footprints."""

    overridden: frozenset[str]
    footprints: tuple[Footprint, ...]


def observed_layer(state: Mapping | Iterable, model: BimModel | None, z_band: tuple[float, float],
                   frame: GridFrame) -> ObservedLayer:
    """Read the twin's state into footprints (see the module docstring for what each entry must have)."""
    overridden, footprints = set(), []
    for key, entry in _entries(state):
        global_id = getattr(entry, "global_id", None) or (key if isinstance(key, str) else None)
        in_bim = model is not None and global_id is not None and model.has_mesh(global_id)
        status = _status_value(getattr(entry, "status", None))
        pose = getattr(entry, "pose", None)
        if status in _CLEAR:
            if in_bim:
                overridden.add(global_id)
            continue
        if status in _KEEP_BIM or pose is None:
            continue
        vertices, faces = _world_mesh(entry, key, global_id if in_bim else None, model, _pose(pose, key))
        if in_bim:
            overridden.add(global_id)
        cells = mesh_cells(vertices, faces, z_band, frame)
        if cells is not None:
            name = getattr(entry, "family", None) or getattr(entry, "name", None) or global_id or str(key)
            footprints.append(Footprint(str(name), "object", *cells, global_id=global_id))
    return ObservedLayer(frozenset(overridden), tuple(footprints))


def _entries(state) -> Iterable[tuple[object, object]]:
    if isinstance(state, Mapping):
        return state.items()
    return enumerate(state)


def _status_value(status) -> str | None:
    if status is None:
        return None
    return status.value if isinstance(status, ElementStatus) else str(status)


def _pose(pose, key) -> np.ndarray:
    T = np.asarray(pose, float)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise PlanningError(f"observed object {key}: pose must be a finite 4x4 matrix (got shape {T.shape})")
    return T


def _world_mesh(entry, key, bim_id: str | None, model: BimModel | None,
                T_world_model: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The object's mesh in world metres at its observed pose."""
    if bim_id is not None:
        vertices_world, faces = model.mesh(bim_id)
        T = T_world_model @ np.linalg.inv(model.element(bim_id).placement)
        return vertices_world @ T[:3, :3].T + T[:3, 3], faces
    mesh = getattr(entry, "mesh", None)
    if mesh is None:
        raise PlanningError(f"observed object {key}: not a BIM element and no mesh given (set .mesh to its body "
                            f"mesh so its footprint is known)")
    vertices, faces = (mesh.vertices, mesh.faces) if hasattr(mesh, "vertices") else mesh
    vertices = np.asarray(vertices, float)
    return vertices @ T_world_model[:3, :3].T + T_world_model[:3, 3], np.asarray(faces)
