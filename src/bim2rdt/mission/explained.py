"""Whose points a fit shows: a fit is evidence of an object only through points no known surface already explains.

The detector keeps what the BIM's building does not explain. Judged ray by ray only, at a
silhouette a pixel's ray can pass beside a column while the point it measured (a time-of-flight mixed pixel, a
camera pose a few mm off) lies on the column, so a strip of the column's edge would reach the mission as an object's
points, and a thin family fits such a strip: a tripod leg fits a column's vertical edge to a few mm (the demo's
frame 2: 129 points of Column C11's corner). By its own distances that fit is excellent; what is wrong is that
its points are already explained, by an element the BIM puts there. The detector also measures what its
rays leave against every permanent surface in 3-D (:func:`bim2rdt.perception.background.on_any_surface`), so
such a strip does not reach the mission (from any detector: every detection's points pass that test).
This check stays for what perception cannot know, the objects registered earlier in the mission, and as a
judge of the fit as a whole rather than of single points.

So, of the points a fit explains (its inliers: within ``IcpConfig.score_distance`` of the fitted model's
surface), the mission asks which of them lie on a known surface: the building's permanent elements, at their
BIM placement (they do not wander), and the objects registered before it (at their fitted pose). When at least
``explained_fraction`` of the inliers lie within ``explained_distance`` of one such surface, the fit shows that
surface, not an object: it is unverified, "its points lie on IfcColumn 'Column C11'". A genuine object standing
against a wall is not caught: the wall hides the face that touches it, and the faces it shows stand off the
wall by the object's own depth. Distances are to the surfaces' triangles, exactly: an element's edge, where a
sampled surface is sparsest, is where a phantom's points lie.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.perception import SLAB_CLASSES
from bim2rdt.perception import permanent_elements
from bim2rdt.perception import KnownSurface


def building_surfaces(model: BimModel) -> list[KnownSurface]:
    """The surfaces of ``model``'s permanent elements (walls, columns, beams, doors ...: what the detector's
    scan-vs-BIM explains a frame with), at their BIM placement. Slabs are left out: the mission already takes
    the points near the slab for slab (``MissionConfig.ground_clearance``), and every object stands on it.

    Args:
        model: The BIM, loaded with geometry.

    Returns:
        One surface per permanent element that is not a slab, triangles in world metres.
    """
    return [KnownSurface.of_element(model, element) for element in permanent_elements(model)
            if element.ifc_class not in SLAB_CLASSES]


@dataclass(frozen=True)
class Explanation:
    """The known surface that explains most of a fit's inliers: its ``name``, how many of the ``inliers`` lie on
    it (``explained``), and the ``distance`` (m) that counted as on it."""

    name: str
    explained: int
    inliers: int
    distance: float

    @property
    def fraction(self) -> float:
        return self.explained / self.inliers

    def reason(self) -> str:
        """What follows "unverified" in a report."""
        return (f"(its points lie on {self.name}: {self.explained} of the {self.inliers} it fits, within "
                f"{100 * self.distance:.0f} cm)")


def explaining_surface(inliers_world: np.ndarray, known: Sequence[KnownSurface],
                       distance: float) -> Explanation | None:
    """The known surface with the most of the fit's inliers (N, 3) within ``distance`` m of it, or None when
    no inlier lies on any."""
    if len(inliers_world) == 0 or not known:
        return None
    counts = [int(np.sum(np.isfinite(surface.distances(inliers_world, distance)))) for surface in known]
    best = int(np.argmax(counts))
    return Explanation(known[best].name, counts[best], len(inliers_world), distance) if counts[best] else None


def fit_inliers(object_pts: np.ndarray, fitted: KnownSurface, score_distance: float) -> np.ndarray:
    """The object's points (N, 3) within ``score_distance`` m of the fitted model's surface: those the fit
    explains (the registration's inliers)."""
    return object_pts[np.isfinite(fitted.distances(object_pts, score_distance))]
