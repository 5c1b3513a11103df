"""Known surfaces and exact point-to-surface distances: how far a measured point is from a BIM element's triangles.

Used where a point must be judged against a surface in 3-D rather than along its own ray: the detector's
scan-vs-BIM (:mod:`bim2rdt.perception.background`: a point on a column's edge whose ray passes just beside the
column), and the mission's check of whose points a fit shows (:mod:`bim2rdt.mission.explained`). Distances are
to the triangles, exactly: an element's edge, where a sampled surface is sparsest, is where such points lie.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import trimesh

from bim2rdt.bim import BimElement, BimModel


@dataclass(frozen=True)
class KnownSurface:
    """A surface known to be there: ``name`` for reports ("IfcColumn 'Column C11'") and its ``triangles``
    (T, 3, 3) in world metres."""

    name: str
    triangles: np.ndarray = field(repr=False)

    @classmethod
    def of_mesh(cls, name: str, mesh: trimesh.Trimesh, T_world_model: np.ndarray = np.eye(4)) -> KnownSurface:
        """The surface of a mesh posed in the world.

        Args:
            name: How reports name the surface.
            mesh: The mesh in its body frame, metres.
            T_world_model: 4x4 body-to-world pose, metres.

        Returns:
            The surface, its triangles in world metres.
        """
        triangles = np.asarray(mesh.triangles, dtype=float)
        return cls(name, triangles @ T_world_model[:3, :3].T + T_world_model[:3, 3])

    @classmethod
    def of_element(cls, model: BimModel, element: BimElement) -> KnownSurface:
        """The surface of one of a model's elements at its BIM placement.

        Args:
            model: The BIM, loaded with geometry.
            element: One of its elements.

        Returns:
            The surface, named by IFC class and name (or GlobalId), its triangles in world metres.

        Raises:
            BimError: The model was loaded without geometry.
        """
        vertices, faces = model.mesh(element.global_id)
        name = f"{element.ifc_class} '{element.name}'" if element.name else f"{element.ifc_class} {element.global_id}"
        return cls(name, np.asarray(vertices, dtype=float)[np.asarray(faces)])

    @cached_property
    def bounds(self) -> np.ndarray:
        """The surface's axis-aligned box: a building has hundreds of elements, and most of them are nowhere near
        the points asked about.

        Returns:
            (2,3) the lowest and highest corner, world metres.
        """
        corners = self.triangles.reshape(-1, 3)
        return np.array([corners.min(axis=0), corners.max(axis=0)])

    def closest_points(self, points_world: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray]:
        """The near (point, triangle) pairs: (K,) index into ``points_world`` (N, 3) and (K, 3) the closest point
        of that triangle to it, world metres. Every triangle within ``reach`` m of a point is paired with it
        (only the points in the surface's box and the triangles whose box holds one, both grown by ``reach``,
        are measured).

        Args:
            points_world: (N,3) points, world metres.
            reach: How far from a point a triangle may be and still be paired, metres.

        Returns:
            ((K,) index into ``points_world``, (K,3) closest point of the paired triangle, world metres).
        """
        inside = np.flatnonzero(np.all((points_world >= self.bounds[0] - reach)
                                       & (points_world <= self.bounds[1] + reach), axis=1))
        if len(inside) == 0:
            return inside, np.zeros((0, 3))
        points = points_world[inside]
        point, triangle = _in_boxes(points, self.triangles.min(axis=1) - reach, self.triangles.max(axis=1) + reach)
        if len(point) == 0:
            return point, np.zeros((0, 3))
        return inside[point], trimesh.triangles.closest_point(self.triangles[triangle], points[point])

    def distances(self, points_world: np.ndarray, reach: float) -> np.ndarray:
        """The distance of each point to the surface.

        Args:
            points_world: (N,3) points, world metres.
            reach: Distances beyond this many metres are not measured.

        Returns:
            (N,) distances, metres; inf where the surface is farther than ``reach``.
        """
        out = np.full(len(points_world), np.inf)
        index, closest = self.closest_points(points_world, reach)
        np.minimum.at(out, index, np.linalg.norm(closest - points_world[index], axis=1))
        return np.where(out <= reach, out, np.inf)


def _in_boxes(points: np.ndarray, low: np.ndarray, high: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The (point, box) index pairs of points (n, 3) inside boxes (T, 3) ``low`` to ``high``: a sweep along x
    (each box takes the run of x-sorted points across its x-range, then y and z are checked), so a detailed
    element (a spiral stair of thousands of triangles) costs its pairs, not points x triangles."""
    order = np.argsort(points[:, 0])
    xs = points[order, 0]
    first, last = np.searchsorted(xs, low[:, 0], side="left"), np.searchsorted(xs, high[:, 0], side="right")
    counts = last - first
    box = np.repeat(np.arange(len(low)), counts)
    step = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
    point = order[np.repeat(first, counts) + step]
    inside = np.all((points[point, 1:] >= low[box, 1:]) & (points[point, 1:] <= high[box, 1:]), axis=1)
    return point[inside], box[inside]
