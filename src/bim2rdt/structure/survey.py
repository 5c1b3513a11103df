"""The evidence each view gives about each permanent element, gathered over the views.

For one view (returns in the sensor frame, the BIM-fixed pose):

1. each return's ray is cast at the model (:class:`~bim2rdt.structure.scene.JudgeScene`: other bodies hide what is
   behind them); its signed distance along the face normal ``s = (t - r) cos`` says whether it lies on the face
   (``|s| <= on_band``), beyond it (``s < -through_margin``: the face was seen through) or before it (clutter);
2. rays spread over the whole sphere find each element's sensor-facing surface from where the sensor stood (in
   range, not hidden): the coverage's denominator, counted in surface cells so several views make a union;
3. the pose is refitted on the other elements' returns, leaving each judged element out in turn
   (:mod:`~bim2rdt.structure.refit`), and the element's returns measured from that pose.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.localization import GRAZING_COS, sphere_directions
from bim2rdt.structure.config import StructureConfig, StructureTolerance
from bim2rdt.structure.refit import UP, Pairs, consensus, pin_weight, refit
from bim2rdt.structure.records import StructureView
from bim2rdt.structure.scene import Cast, JudgeScene

FACE_SAMPLES = 4000
"""At most this many returns per face and view are kept for the face's tilt."""


@dataclass
class FaceEvidence:
    """The returns on one face direction of an element: its unit ``normal`` (towards the sensor), the signed
    distances ``rho`` (m, from the leave-one-out pose) and the returns' world ``points``."""

    normal: np.ndarray
    rho: list[np.ndarray] = field(default_factory=list)
    points: list[np.ndarray] = field(default_factory=list)

    @property
    def count(self) -> int:
        return sum(len(r) for r in self.rho)


@dataclass
class ElementEvidence:
    """What the views say about one element: surface cells ``visible`` from the sensors, ``covered`` by returns on
    them, seen ``through``, in ``clear`` view (on or through); its ``faces``; the ``frames`` that saw it; the face
    normals the other elements did not pin (``unpinned``)."""

    visible: set = field(default_factory=set)
    covered: set = field(default_factory=set)
    through: set = field(default_factory=set)
    clear: set = field(default_factory=set)
    faces: dict = field(default_factory=dict)
    frames: set = field(default_factory=set)
    unpinned: set = field(default_factory=set)


class StructureSurvey:
    """Evidence about the model's permanent elements, one view at a time (see the module's note); the judge reads
    :attr:`evidence`.

    Args:
        model: The BIM, loaded with geometry.
        config: The judge's settings.
    """

    def __init__(self, model: BimModel, config: StructureConfig) -> None:
        self.model, self.config = model, config
        self.scene = JudgeScene.of(model)
        self.evidence: dict[str, ElementEvidence] = {}
        self._sphere = sphere_directions(config.sphere_step_deg)

    def add(self, view: StructureView) -> None:
        """Gather one view's evidence.

        Args:
            view: The returns (sensor frame) and the BIM-fixed pose.
        """
        centre, directions, ranges = self._rays(view)
        self._visible(centre)
        if len(ranges) == 0:
            return
        first = self.scene.cast(centre, directions)
        on_first, through_first, first_keys = self._classify(first, ranges, centre, directions)
        self._tally(view.index, first, np.zeros(len(ranges), bool), through_first, first_keys)
        cast = self._beyond(first, through_first, centre, directions)
        on, through, keys = self._classify(cast, ranges, centre, directions)
        ambiguous = self._ambiguous(first, on_first, through_first, ranges, centre, directions)
        self._tally(view.index, cast, on, through, keys, decisive=~ambiguous)
        seen_through = self._seen_through(first, on_first & ~ambiguous, through_first)
        self._measure_all(cast, on, ranges, centre, directions, seen_through)

    def _tally(self, index: int, cast: Cast, on: np.ndarray, through: np.ndarray, keys: np.ndarray,
               decisive: np.ndarray | None = None) -> None:
        """Each judged element's cells covered (``on``), seen through, in clear view (either, where ``decisive``:
        a return on a face that lies on the surface behind it too says nothing of whether the face is built), and
        the frame."""
        decisive = np.ones(len(on), bool) if decisive is None else decisive
        for element in np.unique(cast.element[on | through]):
            if not self.scene.judged[element]:
                continue
            seen, mine = self._of(element), cast.element == element
            seen.covered.update(keys[mine & on].tolist())
            seen.through.update(keys[mine & through].tolist())
            seen.clear.update(keys[mine & (on | through) & decisive].tolist())
            seen.frames.add(index)

    def _ambiguous(self, first: Cast, on_first: np.ndarray, through_first: np.ndarray, ranges: np.ndarray,
                   centre: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """(K,) the returns on the first face of an element the view sees through somewhere whose ray meets another
        element's face, or leaves the element through a face other than its back face, before ``on_band`` past the
        return: where the element ends at a wall or the floor, a return there lies as much on the surface behind
        it, so it says neither that the element is built nor that it is not (a thin door leaf's back face, within
        the band, leaves its returns decisive)."""
        ambiguous = np.zeros(len(ranges), bool)
        suspects = np.unique(first.element[through_first])
        rows = on_first & np.isin(first.element, suspects[suspects >= 0])
        if not rows.any():
            return ambiguous
        index = np.flatnonzero(rows)
        start = first.t[index] + 1e-3
        reach = ranges[index] + self.config.on_band / np.maximum(first.cos[index], GRAZING_COS)
        again = self.scene.cast_each(centre + directions[index] * start[:, None], directions[index])
        back = (again.element == first.element[index]) & (np.abs(np.einsum(
            "ni,ni->n", again.normal, first.normal[index])) >= 0.9)  # its own back face: a thin leaf's, not an end
        ambiguous[index] = (again.element >= 0) & (again.t + start <= reach) & ~back
        return ambiguous

    def _seen_through(self, first: Cast, decisive_on: np.ndarray, through_first: np.ndarray) -> set[int]:
        """The elements this view sees through over more than ``partly_through`` of their decisive returns (on
        them, not also on the surface behind, or through them), with ``min_points`` through: at best partly built
        here, so they must not fix the pose the others are measured from."""
        out = set()
        for element in np.unique(first.element[through_first]):
            through = int(np.sum(through_first & (first.element == element)))
            on = int(np.sum(decisive_on & (first.element == element)))
            if through >= self.config.min_points and through > self.config.partly_through * (through + on):
                out.add(int(element))
        return out

    def _measure_all(self, cast: Cast, on: np.ndarray, ranges: np.ndarray, centre: np.ndarray,
                     directions: np.ndarray, seen_through: set[int] = frozenset()) -> None:
        """The returns on faces as pairs, the consensus of the elements (those ``seen_through`` left out), each
        judged element measured."""
        scene, cfg = self.scene, self.config
        points = centre + directions[on] * ranges[on, None]
        element = cast.element[on]
        fixes = scene.in_map[element] & ~np.isin(element, list(seen_through))
        pairs = Pairs.of(points, centre + directions[on] * cast.t[on, None], cast.normal[on], element, fixes,
                         centre)
        tolerance = {int(i): tolerance_of(scene.classes[i], cfg).translation for i in np.unique(element)}
        agreed = consensus(pairs, tolerance, cfg.huber, cfg.min_face_points, cfg.min_pin_points)
        for index in np.unique(element):
            if scene.judged[index]:
                self._measure(index, pairs, agreed, points, centre)

    def _classify(self, cast: Cast, ranges: np.ndarray, centre: np.ndarray, directions: np.ndarray):
        """(on, through, cell keys) of each return against its ray's face: on within ``on_band`` of it along the
        normal, through beyond ``through_margin``."""
        cfg = self.config
        hit = (cast.element >= 0) & (cast.t <= cfg.max_range * 1.2)
        t = np.where(hit, cast.t, 0.0)
        s = np.where(hit, (t - ranges) * cast.cos, 0.0)
        on = hit & (np.abs(s) <= cfg.on_band)
        through = hit & (s < -cfg.through_margin)
        return on, through, cell_keys(centre + directions * t[:, None], cfg.cell)

    def _beyond(self, cast: Cast, through: np.ndarray, centre: np.ndarray, directions: np.ndarray) -> Cast:
        """The cast with each ray seen through its first face carried on to the next face behind it: a wall not
        built hides nothing, and what lies behind it is judged on those returns."""
        if not through.any():
            return cast
        t, element, normal, cos = cast.t.copy(), cast.element.copy(), cast.normal.copy(), cast.cos.copy()
        front = cast.front.copy()
        rows, start = np.flatnonzero(through), cast.t[through] + 0.01
        for _ in range(6):  # past the far faces of what was seen through (a wall's back, a body inside it)
            again = self.scene.cast_each(centre + directions[rows] * start[:, None], directions[rows])
            t[rows] = np.where(again.element >= 0, again.t + start, np.inf)
            element[rows], normal[rows], cos[rows], front[rows] = again.element, again.normal, again.cos, again.front
            inside = (again.element >= 0) & ((again.element == cast.element[rows]) | ~again.front)
            rows, start = rows[inside], t[rows][inside] + 0.01
            if len(rows) == 0:
                break
        element[rows] = -1  # still inside after that many faces: nothing to judge
        return Cast(t, element, normal, cos, front)

    def _rays(self, view: StructureView) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The view's sensor position, unit world directions of its returns beyond ``min_range`` (thinned evenly to
        ``points_per_view``) and their ranges (m). Faces beyond ``max_range`` are never judged (:meth:`_classify`)."""
        cfg = self.config
        points = view.points_sensor[np.all(np.isfinite(view.points_sensor), axis=1)]
        ranges = np.linalg.norm(points, axis=1)
        keep = ranges >= cfg.min_range  # a far return still says the sensor saw through what stands before it
        points, ranges = points[keep], ranges[keep]
        step = max(1, -(-len(points) // cfg.points_per_view))
        points, ranges = points[::step], ranges[::step]
        directions = (points / ranges[:, None]) @ view.pose[:3, :3].T
        return view.pose[:3, 3], directions, ranges

    def _visible(self, centre: np.ndarray) -> None:
        """Each judged element's surface cells the sensor at ``centre`` could see (rays over the sphere)."""
        cast = self.scene.cast(centre, self._sphere)
        ok = (cast.element >= 0) & (cast.t <= self.config.max_range)
        keys = cell_keys(centre + self._sphere * np.where(ok, cast.t, 0.0)[:, None], self.config.cell)
        for index in np.unique(cast.element[ok]):
            if self.scene.judged[index]:
                self._of(index).visible.update(keys[ok & (cast.element == index)].tolist())

    def _measure(self, index: int, pairs: Pairs, agreed: np.ndarray, points: np.ndarray, centre: np.ndarray) -> None:
        """The element's returns measured from the pose refitted on the other elements of the consensus
        (leave-one-out)."""
        cfg = self.config
        mine = pairs.element == index
        others = agreed & ~mine
        x = refit(pairs, others, cfg.huber)
        rho = pairs.rho[mine] + pairs.jacobian[mine] @ x
        placed = points[mine] + x[:3] + x[3] * np.cross(UP, points[mine] - centre)
        seen = self._of(index)
        groups = np.round(pairs.normal[mine] * 10).astype(int)
        for key in {tuple(g) for g in groups.tolist()}:
            face = np.all(groups == key, axis=1)
            normal = pairs.normal[mine][face].mean(axis=0)
            normal /= np.linalg.norm(normal)
            evidence = seen.faces.setdefault(key, FaceEvidence(normal))
            step = max(1, -(-int(face.sum()) // FACE_SAMPLES))
            evidence.rho.append(rho[face][::step])
            evidence.points.append(placed[face][::step])
            if face.sum() >= cfg.min_face_points and pin_weight(pairs, others, normal, cfg.huber) < cfg.min_pin_points:
                seen.unpinned.add(key)

    def _of(self, index: int) -> ElementEvidence:
        return self.evidence.setdefault(self.scene.ids[index], ElementEvidence())


def tolerance_of(ifc_class: str, config: StructureConfig) -> StructureTolerance:
    """The class's tolerance (the configured default for a class the table does not name).

    Args:
        ifc_class: The element's IFC class.
        config: The judge's settings.

    Returns:
        The tolerance.
    """
    return config.tolerances.get(ifc_class, config.default_tolerance)


def cell_keys(points: np.ndarray, cell: float) -> np.ndarray:
    """One int64 per ``cell``-sized cube of the world (K,) for points (K, 3), metres (within +-100 km at 0.1 m)."""
    ijk = np.floor(points / cell).astype(np.int64) + (1 << 20)
    return (ijk[:, 0] << 42) | (ijk[:, 1] << 21) | ijk[:, 2]
