"""How well a candidate pose explains the whole view, occlusion and free space included: the score the global
search ranks refined candidates by, and decides ambiguity on (:func:`~bim2rdt.localization.choose`).

Each of the cloud's points (walls, floor, clutter alike: an even draw) is followed along its ray from the pose to
the first surface of the model (the permanent map, the model's other bodies occluding):

- **on**: it lies on that surface (within ``on`` m of its plane, along its normal: a surface seen at a grazing
  angle is not missed for a pose a few centimetres off): +1;
- **through**: it lies beyond it by more than ``behind`` m (along its normal), so the sensor would have seen through a wall, a
  column or the floor: -1 (a camera cannot; this is what tells apart two places whose walls both fit, where
  one of them would have the floor seen through a wall beyond the view's edge);
- **in front**: it lies short of the surface, in what the model calls free space: 0 (people and site clutter
  do that at the true place too, so it costs only the +1 it does not earn);
- no surface on its ray (seen out of the building), or it lies beyond one of the model's other bodies
  (furniture, a site object that may have moved since): 0.

The surface on a ray may be one of the model's other bodies (a built-in wardrobe explains the points on it).
Every point counts: leaving out those behind the model's other bodies would raise a wrong place's share where
the model puts a site object across the view. The score is (on - through) / points, a share in [-1, 1]: two places a view cannot tell apart score within
the sampling noise of a share (:func:`~bim2rdt.localization.global_search.noise`).

A free-standing thing (a person, a barrow, a column: a piece of the cloud :func:`~.pieces.free_standing` finds
without a pose) counts whole or not at all: its points on a surface earn a pose their +1 only when at least
``whole`` of its points that meet a surface lie on one rather than short of it. At the true place a person is
in free space and earns nothing; at a wrong place part of a person may land on a column or a wall's end, and
without this rule earns that place what the truth cannot (the tour's south-west corner turned 30 degrees, a
person in view: a place 13.5 m off scored 0.95 against the truth's 0.85). A permanent thing the model has is on
its surface whole at the true place. Points seen through a surface cost their -1 either way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bim2rdt.localization.cloud import OccludedMap


@dataclass(frozen=True)
class Evidence:
    """Counts of a pose's points by what their ray meets (see the module's note)."""

    on: int
    through: int
    in_front: int
    counted: int

    @property
    def score(self) -> float:
        """(on - through) / counted, in [-1, 1]; 0 when nothing is counted."""
        return (self.on - self.through) / max(self.counted, 1)


class ViewScore:
    """The score of poses for one cloud's points against one model (see the module's note)."""

    def __init__(self, points: np.ndarray, scene: OccludedMap, on: float, behind: float,
                 things: np.ndarray | None = None, whole: float = 0.8) -> None:
        """Args:
            points: Sensor-frame points (N, 3), metres, finite.
            scene: The model's permanent map with its other bodies as occluders.
            on: A point within this of the first surface on its ray (along the surface's normal) lies on it, m.
            behind: A point farther than this beyond that surface (along its normal) was seen through it, m.
            things: (N,) the free-standing thing each point belongs to (:func:`~.pieces.free_standing`; negative:
                none, counted on its own); None: every point counted on its own.
            whole: A thing's points on a surface count only when at least this share of its points that meet a
                surface lie on one (0: always).
        """
        self.range = np.linalg.norm(points, axis=1)
        self.unit = points / np.maximum(self.range, 1e-9)[:, None]
        self.scene, self.on, self.behind, self.whole = scene, on, behind, whole
        self.things = None if things is None or not np.any(np.asarray(things) >= 0) else np.asarray(things)

    def evidence(self, pose: np.ndarray) -> Evidence:
        """What the points' rays meet from ``pose``.

        Args:
            pose: T_world_sensor (4, 4).

        Returns:
            The counts.
        """
        if len(self.range) == 0:
            return Evidence(0, 0, 0, 0)
        t, owner, facing = self._first_hits(pose)
        hit = np.isfinite(t)
        gap = np.where(hit, (self.range - np.where(hit, t, 0.0)) * facing, 0.0)  # behind the surface, along its normal
        on = hit & (np.abs(gap) < self.on)
        through = hit & (owner >= 0) & (gap > self.behind)
        front = hit & (gap < -self.on)
        if self.things is not None:
            part = self._in_part(on, front)
            on, front = on & ~part, front | part
        return Evidence(int(on.sum()), int(through.sum()), int(front.sum()), len(t))

    def _in_part(self, on: np.ndarray, front: np.ndarray) -> np.ndarray:
        """The points on a surface whose thing is explained only in part (fewer than ``whole`` of its points
        that meet a surface on one): they earn nothing, as if in front."""
        thing = self.things >= 0
        label = self.things[thing]
        count = int(label.max()) + 1
        on_count = np.bincount(label, on[thing], minlength=count)
        front_count = np.bincount(label, front[thing], minlength=count)
        partial = on_count < self.whole * (on_count + front_count)
        out = np.zeros(len(on), dtype=bool)
        out[thing] = on[thing] & partial[label]
        return out

    def __call__(self, pose: np.ndarray) -> float:
        """The pose's score, (on - through) / counted.

        Args:
            pose: T_world_sensor (4, 4).

        Returns:
            The score in [-1, 1].
        """
        return self.evidence(pose).score

    def _first_hits(self, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(distance m to the first surface on each ray, inf when none; its owner: a map element's index, or
        negative for another body; |cos| of the ray's incidence on it, at least 0.05)."""
        mesh = self.scene.mesh
        directions = self.unit @ pose[:3, :3].T
        origin = pose[:3, 3]
        face = mesh.ray.intersects_first(np.broadcast_to(origin, directions.shape), directions)
        t = np.full(len(face), np.inf)
        hit = face >= 0
        normals = mesh.face_normals[face[hit]]
        corner = mesh.vertices[mesh.faces[face[hit], 0]]
        incidence = np.einsum("ni,ni->n", normals, directions[hit])
        with np.errstate(divide="ignore", invalid="ignore"):
            t[hit] = np.einsum("ni,ni->n", normals, corner - origin) / incidence
        owner = np.full(len(face), -1)
        owner[hit] = self.scene.face_owner[face[hit]]
        facing = np.ones(len(face))
        facing[hit] = np.maximum(np.abs(incidence), 0.05)
        return t, owner, facing
