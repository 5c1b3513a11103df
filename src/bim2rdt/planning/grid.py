"""``OccupancyGrid``: the robot's map of one storey, from the BIM, updated by what the twin observed and by
keep-out zones.

The grid is layers of footprints (see ``raster.Footprint``): the BIM's elements in the robot's height band
(plus closed doors and the floor's edge), the observed objects, and the keep-out zones. ``occupied`` is their
union; ``blocked`` is ``occupied`` grown by the robot's radius, the cells its centre may not enter. A grid is
immutable: ``with_obstacles`` and ``with_zones`` return a new grid, recomputing only the windows around the
footprints that changed.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from bim2rdt.bim import BimModel, BimStorey, BimZone
from bim2rdt.planning.elements import DoorPolicy, check_door_policy, element_footprints, require_walls
from bim2rdt.planning.errors import PlanningError
from bim2rdt.planning.floor import find_floor, floor_extent, floor_mask
from bim2rdt.planning.frame import MAX_CELLS, GridFrame
from bim2rdt.planning.inflation import inflate, reach_cells, reinflate
from bim2rdt.planning.obstacles import observed_layer
from bim2rdt.planning.raster import Footprint
from bim2rdt.planning.zones import KeepOut, zone_footprints

STRUCTURE_KINDS = ("element", "door", "floor edge")
KEEPOUT_KINDS = ("zone", "person")


@dataclass(frozen=True, eq=False)
class OccupancyGrid:
    """One storey's occupancy at ``frame``'s resolution. ``height_band`` is relative to the floor at world height
    ``floor_z``; ``robot_radius`` in metres. ``base`` are the BIM's footprints, ``overridden`` the BIM elements the
    twin has placed elsewhere (or found missing), ``objects`` the observed ones, ``zones`` the keep-out areas."""

    frame: GridFrame
    robot_radius: float
    height_band: tuple[float, float]
    floor_z: float
    storey: str | None
    floor_source: str
    base: tuple[Footprint, ...]
    occupied: np.ndarray = field(repr=False)
    blocked: np.ndarray = field(repr=False)
    overridden: frozenset[str] = frozenset()
    objects: tuple[Footprint, ...] = ()
    zones: tuple[Footprint, ...] = ()
    open_doors: tuple[str, ...] = ()
    model: BimModel | None = field(default=None, repr=False)

    @classmethod
    def from_bim(cls, model: BimModel, storey: str | BimStorey | None = None, resolution: float = 0.05,
                 robot_radius: float = 0.35, height_band: tuple[float, float] = (0.05, 1.2), *,
                 doors: DoorPolicy = "open") -> OccupancyGrid:
        """Slice ``storey`` (name, GlobalId or BimStorey; None = the ground floor) of ``model`` in the robot's
        ``height_band`` above its floor, at ``resolution`` metres per cell, grown by ``robot_radius``. ``doors``:
        ``"open"``, ``"closed"`` or the GlobalIds/names of the closed doors.

        Args:
            model: The BIM, loaded with geometry.
            storey: The storey's name, GlobalId or BimStorey; None takes the ground floor.
            resolution: Cell edge, metres.
            robot_radius: How far obstacles grow for the robot's centre, metres.
            height_band: (low, high) metres above the floor that the robot's body occupies.
            doors: ``"open"``, ``"closed"`` or the GlobalIds/names of the closed doors.

        Returns:
            The grid of that floor.

        Raises:
            PlanningError: Bad numbers or door policy, a model without geometry or walls, no such storey or
                floor, or a grid too large for the resolution.
        """
        _check_numbers(resolution, robot_radius, height_band)
        check_door_policy(doors)
        require_walls(model)
        floor = find_floor(model, storey)
        frame = GridFrame.covering(*floor_extent(model, floor), resolution, robot_radius + 2 * resolution)
        _check_size(frame, resolution)
        z_band = (floor.z + height_band[0], floor.z + height_band[1])
        footprints, open_doors = element_footprints(model, z_band, frame, doors)
        edge = Footprint(f"edge of the {floor.storey.name} floor", "floor edge", 0, 0, ~floor_mask(model, floor, frame))
        base = tuple(footprints) + ((edge,) if edge.mask.any() else ())
        occupied = _union(base, frame.shape)
        return cls(frame, float(robot_radius), (float(height_band[0]), float(height_band[1])), floor.z,
                   floor.storey.name, floor.source, base, occupied,
                   inflate(occupied, reach_cells(robot_radius, resolution)), open_doors=tuple(open_doors), model=model)

    @classmethod
    def from_occupancy(cls, occupied: np.ndarray, resolution: float,
                       origin_xy: np.ndarray | tuple[float, float] = (0.0, 0.0), robot_radius: float = 0.35,
                       name: str = "obstacle map", floor_z: float = 0.0,
                       height_band: tuple[float, float] = (0.05, 1.2)) -> OccupancyGrid:
        """A grid from a bool occupancy array (a SLAM map, a test's maze); its cells are one footprint.

        Args:
            occupied: (rows, cols) bool, rows along world y and columns along x; True is an obstacle.
            resolution: Cell edge, metres.
            origin_xy: World (x, y) of the array's lower-left corner, metres.
            robot_radius: How far obstacles grow for the robot's centre, metres.
            name: The footprint's name, in reports of what blocks a path.
            floor_z: World height of the floor, metres.
            height_band: (low, high) metres above the floor that the robot's body occupies.

        Returns:
            The grid.

        Raises:
            PlanningError: Bad numbers, a non-finite origin or floor, or an array that is not 2-D and non-empty.
        """
        _check_numbers(resolution, robot_radius, height_band)
        origin_xy = _finite_xy(origin_xy, "origin_xy")
        if not (isinstance(floor_z, int | float) and math.isfinite(floor_z)):
            raise PlanningError(f"floor_z must be a finite height in metres (got {floor_z!r})")
        occupied = np.asarray(occupied, bool)
        if occupied.ndim != 2 or occupied.size == 0:
            raise PlanningError(f"occupancy must be a non-empty 2-D array (got shape {occupied.shape})")
        frame = GridFrame((float(origin_xy[0]), float(origin_xy[1])), float(resolution), occupied.shape)
        base = (Footprint(name, "element", 0, 0, occupied.copy()),)
        return cls(frame, float(robot_radius), (float(height_band[0]), float(height_band[1])), float(floor_z), None,
                   "occupancy", base, occupied.copy(), inflate(occupied, reach_cells(robot_radius, resolution)))

    # ---- updates: each returns a new grid --------------------------------------------------------------------

    def with_obstacles(self, twin_state: Mapping | Iterable) -> OccupancyGrid:
        """The grid with the objects of ``twin_state`` where the twin saw them (replacing any observed before):
        a moved BIM element leaves its BIM place, a missing one frees it, a new one is added. See
        ``planning.obstacles`` for what each entry needs (``pose``; ``status``; ``mesh`` for objects the BIM lacks).

        Args:
            twin_state: The twin's state ({GlobalId: ElementState}) or its states.

        Returns:
            A new grid; this one is unchanged.
        """
        layer = observed_layer(twin_state, self.model, self.z_band, self.frame)
        objects = _reuse(self.objects, layer.footprints)
        return self._changed(overridden=layer.overridden, objects=objects)

    def with_zones(self, zones: Iterable[BimZone | KeepOut]) -> OccupancyGrid:
        """The grid with these keep-out zones (replacing any set before): BIM zones tagged off-limits (others are
        skipped, so ``model.zones`` can go in whole) and ``KeepOut`` areas (``worker_keepouts`` for people).

        Args:
            zones: BIM zones and keep-out areas.

        Returns:
            A new grid; this one is unchanged.
        """
        return self._changed(zones=_reuse(self.zones, zone_footprints(zones, self.model, self.z_band, self.frame)))

    # ---- reading -----------------------------------------------------------------------------------------------

    @property
    def resolution(self) -> float:
        """Cell edge, metres."""
        return self.frame.resolution

    @property
    def z_band(self) -> tuple[float, float]:
        """The height band in world metres."""
        return self.floor_z + self.height_band[0], self.floor_z + self.height_band[1]

    @property
    def footprints(self) -> tuple[Footprint, ...]:
        """Every footprint in force: the BIM's (less the overridden), the observed objects, the zones."""
        return tuple(fp for fp in self.base if fp.global_id not in self.overridden) + self.objects + self.zones

    @property
    def reach(self) -> float:
        """How far obstacles grow, in cells (centre to centre)."""
        return reach_cells(self.robot_radius, self.resolution)

    @cached_property
    def cost(self) -> np.ndarray:
        """The path planner's weights.

        Returns:
            (rows, cols) float32 for pyastar2d: 1 where the robot's centre may go, inf where it may not.
        """
        return np.where(self.blocked, np.float32(np.inf), np.float32(1.0)).astype(np.float32)

    def layer(self, kinds: Iterable[str]) -> np.ndarray:
        """The cells covered by footprints of some kinds.

        Args:
            kinds: Footprint kinds (e.g. ``KEEPOUT_KINDS``).

        Returns:
            (rows, cols) bool.
        """
        kinds = tuple(kinds)
        return self.layer_of([fp for fp in self.footprints if fp.kind in kinds])

    def layer_of(self, footprints: Iterable[Footprint]) -> np.ndarray:
        """The cells covered by some footprints.

        Args:
            footprints: The footprints.

        Returns:
            (rows, cols) bool.
        """
        return _union(footprints, self.frame.shape)

    def is_free(self, xy: np.ndarray | tuple[float, float]) -> bool:
        """Whether the robot's centre may stand at a world point.

        Args:
            xy: World (x, y), metres.

        Returns:
            True inside the grid and clear of every grown obstacle.
        """
        cell = self.frame.cell_of(xy)
        return self.frame.contains(cell) and not self.blocked[cell]

    def blockers_at(self, xy: np.ndarray | tuple[float, float]) -> list[tuple[Footprint, float]]:
        """The footprints that block a world point.

        Args:
            xy: World (x, y), metres.

        Returns:
            (footprint, distance from the point in metres; 0 when it is inside), nearest first.
        """
        cell = np.array(self.frame.cell_of(xy))
        found = []
        margin = int(math.ceil(self.reach))
        for fp in self.footprints:
            rows, cols = fp.window
            if not (rows.start - margin <= cell[0] < rows.stop + margin
                    and cols.start - margin <= cell[1] < cols.stop + margin):
                continue
            rows, cols = np.nonzero(fp.mask)
            gap = np.min(np.hypot(rows + fp.row0 - cell[0], cols + fp.col0 - cell[1]))
            if gap < self.reach:
                found.append((fp, float(gap) * self.resolution))
        return sorted(found, key=lambda item: item[1])

    def nearest_free(self, xy: np.ndarray | tuple[float, float], max_distance: float = 2.0) -> np.ndarray | None:
        """The free place nearest a world point.

        Args:
            xy: World (x, y), metres.
            max_distance: How far to look, metres.

        Returns:
            ``xy`` itself when free, else the world (x, y) centre of the nearest free cell within
                ``max_distance``, or None.
        """
        if self.is_free(xy):
            return np.asarray(xy, float)
        radius = int(math.ceil(max_distance / self.resolution))
        row, col = self.frame.cell_of(xy)
        r0, c0 = max(row - radius, 0), max(col - radius, 0)
        window = self.blocked[r0:row + radius + 1, c0:col + radius + 1]
        rows, cols = np.nonzero(~window)
        if not len(rows):
            return None
        centres = self.frame.centres(rows + r0, cols + c0)
        distances = np.linalg.norm(centres - np.asarray(xy, float), axis=1)
        best = int(np.argmin(distances))
        return centres[best] if distances[best] <= max_distance else None

    def save_nav2(self, folder: str | Path, name: str = "site") -> dict[str, Path]:
        """Write ``name.pgm`` + ``name.yaml`` (ROS map_server) and, when there are keep-out zones,
        ``name_keepout.pgm`` + ``.yaml`` (a Nav2 keep-out filter mask).

        Args:
            folder: The output folder.
            name: The file stem.

        Returns:
            {what: path} of the written files.

        Raises:
            PlanningError: A name that is not a plain file stem, or a folder that cannot be written.
        """
        from bim2rdt.planning.nav2 import save_nav2

        obstacles = self.layer(STRUCTURE_KINDS + ("object",))
        return save_nav2(obstacles, self.layer(KEEPOUT_KINDS), self.frame, Path(folder), name)

    # ---- internals ---------------------------------------------------------------------------------------------

    def _changed(self, **layers) -> OccupancyGrid:
        """A new grid with some layers replaced; occupied/blocked recomputed only around what changed."""
        draft = dataclasses.replace(self, **layers)
        before, after = self.footprints, draft.footprints
        ids_before, ids_after = {id(fp) for fp in before}, {id(fp) for fp in after}
        removed = [fp for fp in before if id(fp) not in ids_after]
        added = [fp for fp in after if id(fp) not in ids_before]
        if not removed and not added:
            return draft
        occupied, blocked = self.occupied.copy(), self.blocked.copy()
        for fp in removed:
            occupied[fp.window] = False
        for fp in removed:
            _redraw(occupied, fp.window, after)
        for fp in added:
            occupied[fp.window] |= fp.mask
        for fp in removed + added:
            reinflate(blocked, occupied, fp.window, self.reach)
        return dataclasses.replace(draft, occupied=occupied, blocked=blocked)


def _check_numbers(resolution: float, robot_radius: float, height_band: tuple[float, float]) -> None:
    if not (isinstance(resolution, int | float) and math.isfinite(resolution) and resolution > 0):
        raise PlanningError(f"resolution must be a number of metres > 0 (got {resolution!r})")
    if not (isinstance(robot_radius, int | float) and math.isfinite(robot_radius) and robot_radius >= 0):
        raise PlanningError(f"robot_radius must be a number of metres >= 0 (got {robot_radius!r})")
    low, high = height_band
    if not (math.isfinite(low) and math.isfinite(high) and 0 <= low < high):
        raise PlanningError(f"height_band must be (low, high) metres above the floor with 0 <= low < high "
                            f"(got {tuple(height_band)!r})")


def _finite_xy(xy, what: str) -> tuple[float, float]:
    try:
        point = np.asarray(xy, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        point = np.array([])
    if point.shape != (2,) or not np.all(np.isfinite(point)):
        raise PlanningError(f"{what} must be a finite (x, y) in metres (got {xy!r})")
    return float(point[0]), float(point[1])


def _check_size(frame: GridFrame, resolution: float) -> None:
    rows, cols = frame.shape
    if rows * cols > MAX_CELLS:
        raise PlanningError(f"a {resolution:g} m grid of this storey has {rows} x {cols} cells (more than "
                            f"{MAX_CELLS:,}): use a coarser resolution")


def _union(footprints: Iterable[Footprint], shape: tuple[int, int]) -> np.ndarray:
    occupied = np.zeros(shape, bool)
    for fp in footprints:
        occupied[fp.window] |= fp.mask
    return occupied


def _redraw(occupied: np.ndarray, window: tuple[slice, slice], footprints: Iterable[Footprint]) -> None:
    """OR every footprint's part inside ``window`` back into ``occupied``."""
    rows, cols = window
    for fp in footprints:
        fr, fc = fp.window
        r0, r1 = max(rows.start, fr.start), min(rows.stop, fr.stop)
        c0, c1 = max(cols.start, fc.start), min(cols.stop, fc.stop)
        if r0 < r1 and c0 < c1:
            occupied[r0:r1, c0:c1] |= fp.mask[r0 - fp.row0:r1 - fp.row0, c0 - fp.col0:c1 - fp.col0]


def _reuse(current: tuple[Footprint, ...], fresh: Iterable[Footprint]) -> tuple[Footprint, ...]:
    """``fresh`` footprints, each replaced by an identical current one where there is one (so an object seen
    again in the same place costs no recomputation)."""
    kept = []
    for fp in fresh:
        same = next((old for old in current if _same(old, fp)), None)
        kept.append(same or fp)
    return tuple(kept)


def _same(a: Footprint, b: Footprint) -> bool:
    return (a.name, a.kind, a.global_id, a.row0, a.col0, a.mask.shape) == (b.name, b.kind, b.global_id, b.row0, b.col0,
                                                                          b.mask.shape) and np.array_equal(a.mask, b.mask)

