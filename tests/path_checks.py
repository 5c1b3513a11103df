"""Independent checks of planned paths: against the BIM's wall meshes (ray casting), and against a grid."""

from __future__ import annotations

import numpy as np
import trimesh

WALL_CLASSES = ("IfcWall", "IfcCurtainWall", "IfcColumn")


def wall_mesh(model) -> trimesh.Trimesh:
    """Every wall and column of a model as one mesh (world metres)."""
    parts = [trimesh.Trimesh(*model.mesh(el.global_id), process=False) for el in model.elements
             if el.ifc_class.startswith(WALL_CLASSES) and model.has_mesh(el.global_id)]
    return trimesh.util.concatenate(parts)


def segments_through(mesh: trimesh.Trimesh, path_xy: np.ndarray, heights=(0.1, 0.6, 1.1)) -> list[tuple[int, float]]:
    """(segment index, height) of every path segment that crosses the mesh at one of ``heights`` above z = 0."""
    crossings = []
    for index, (a, b) in enumerate(zip(path_xy[:-1], path_xy[1:])):
        length = float(np.linalg.norm(b - a))
        if length == 0.0:
            continue
        for z in heights:
            origin = np.array([[a[0], a[1], z]])
            direction = np.array([[(b - a)[0] / length, (b - a)[1] / length, 0.0]])
            hits, _, _ = mesh.ray.intersects_location(origin, direction)
            if len(hits) and np.min(np.linalg.norm(hits - origin, axis=1)) < length:
                crossings.append((index, z))
    return crossings


def samples_free(grid, path_xy: np.ndarray, step: float = 0.01) -> bool:
    """True when every point along the path (every ``step`` m) is free in ``grid``."""
    for a, b in zip(path_xy[:-1], path_xy[1:]):
        count = max(int(np.linalg.norm(b - a) / step), 1) + 1
        if not all(grid.is_free(a + t * (b - a)) for t in np.linspace(0.0, 1.0, count)):
            return False
    return True
