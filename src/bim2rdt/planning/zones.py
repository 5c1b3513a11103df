"""Keep-out zones: areas the robot's body must stay out of.

Two sources:
- the BIM: spaces and zones tagged off-limits (``BimZone.off_limits``, the ``BIM2RDT_Zone`` pset), drawn from
  their space geometry; untagged or allowed zones (a work zone) are not keep-out, so ``model.zones`` can be
  passed whole;
- people: a circle around each worker, larger while that worker's hand-arm vibration activity is live (the HAV
  monitor's ``hav.activity_started``/``hav.activity_ended`` events say when). Positions and live flags come in
  as plain values; where they come from (a tag, the robot's camera, the simulator) is the caller's business.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from bim2rdt.bim import BimModel, BimZone
from bim2rdt.planning.errors import PlanningError
from bim2rdt.planning.frame import GridFrame
from bim2rdt.planning.raster import Footprint, disc_cells, mesh_cells, polygon_cells
from bim2rdt.safety import ACTIVITY_ENDED, ACTIVITY_STARTED

WORKER_RADIUS = 1.0
"""Keep-out radius around a worker, m: room to pass without crowding them."""
WORKER_LIVE_RADIUS = 3.0
"""Keep-out radius around a worker whose tool is running, m: grinding sparks and chips fly a few metres, and a
robot at the edge of a worker's vision is a distraction while they hold a vibrating tool."""


@dataclass(frozen=True)
class KeepOut:
    """A keep-out area in world metres: a polygon (``polygon_xy`` (N, 2)) or a circle (``centre_xy``,
    ``radius``). ``kind`` is ``zone`` or ``person`` (reports and the Nav2 keep-out mask show both)."""

    name: str
    polygon_xy: tuple[tuple[float, float], ...] | None = None
    centre_xy: tuple[float, float] | None = None
    radius: float = 0.0
    kind: str = "zone"

    @classmethod
    def circle(cls, name: str, centre_xy: tuple[float, float] | np.ndarray, radius: float,
               kind: str = "zone") -> KeepOut:
        """A circular keep-out area.

        Args:
            name: How reports name it.
            centre_xy: World (x, y) of the centre, metres.
            radius: Metres.
            kind: ``zone`` or ``person``.

        Returns:
            The area.

        Raises:
            PlanningError: The radius is not positive.
        """
        if not radius > 0:
            raise PlanningError(f"keep-out {name!r}: radius must be > 0 m (got {radius})")
        return cls(name, centre_xy=(float(centre_xy[0]), float(centre_xy[1])), radius=float(radius), kind=kind)

    @classmethod
    def polygon(cls, name: str, polygon_xy: np.ndarray | list[tuple[float, float]], kind: str = "zone") -> KeepOut:
        """A polygonal keep-out area.

        Args:
            name: How reports name it.
            polygon_xy: (K,2) world (x, y) corners, metres, K >= 3.
            kind: ``zone`` or ``person``.

        Returns:
            The area.

        Raises:
            PlanningError: Fewer than 3 corners.
        """
        points = np.asarray(polygon_xy, float).reshape(-1, 2)
        if len(points) < 3:
            raise PlanningError(f"keep-out {name!r}: a polygon needs at least 3 corners (got {len(points)})")
        return cls(name, polygon_xy=tuple(map(tuple, points)), kind=kind)


def worker_keepouts(workers: Iterable[tuple[str, tuple[float, float], bool]], radius: float = WORKER_RADIUS,
                    live_radius: float = WORKER_LIVE_RADIUS) -> list[KeepOut]:
    """A keep-out circle per worker, larger while their tool runs.

    Args:
        workers: ``(name, (x, y) world metres, live)`` per worker.
        radius: Metres, while the worker's tool is idle.
        live_radius: Metres, while it runs.

    Returns:
        One ``person`` circle per worker.

    Raises:
        PlanningError: A radius that is not positive.
    """
    return [KeepOut.circle(name, xy, live_radius if live else radius, kind="person") for name, xy, live in workers]


def zone_footprints(zones: Iterable[BimZone | KeepOut], model: BimModel | None, z_band: tuple[float, float],
                    frame: GridFrame) -> list[Footprint]:
    """Footprints of the keep-out zones among ``zones`` on this grid (BIM zones of other storeys have none)."""
    footprints = []
    for zone in zones:
        if isinstance(zone, KeepOut):
            cells = _keepout_cells(zone, frame)
            kind, name, gid = zone.kind, zone.name, None
        elif isinstance(zone, BimZone):
            if zone.off_limits is not True:
                continue
            cells = _bim_zone_cells(zone, model, z_band, frame)
            kind, name, gid = "zone", zone.name or zone.global_id, zone.global_id
        else:
            raise PlanningError(f"not a zone: {type(zone).__name__} (give a BimZone or a planning.KeepOut)")
        if cells is not None:
            footprints.append(Footprint(name, kind, *cells, global_id=gid))
    return footprints


def _keepout_cells(zone: KeepOut, frame: GridFrame):
    if zone.polygon_xy is not None:
        return polygon_cells(np.asarray(zone.polygon_xy), frame)
    return disc_cells(zone.centre_xy, zone.radius, frame)


def _bim_zone_cells(zone: BimZone, model: BimModel | None, z_band: tuple[float, float], frame: GridFrame):
    """An IfcSpace's own body, or the union of an IfcZone's member spaces, cut by the height band."""
    if model is None:
        raise PlanningError(f"zone {zone.name!r}: this grid has no BIM model to take the zone's shape from")
    members = [gid for gid in (zone.global_id, *zone.member_ids) if model.has_mesh(gid)]
    if not members:
        raise PlanningError(f"{model.path.name}: off-limits zone {zone.name!r} has no geometry to keep out of")
    parts = [mesh_cells(*model.mesh(gid), z_band, frame) for gid in members]
    parts = [p for p in parts if p is not None]
    if not parts:
        return None
    row0, col0 = min(p[0] for p in parts), min(p[1] for p in parts)
    row1 = max(p[0] + p[2].shape[0] for p in parts)
    col1 = max(p[1] + p[2].shape[1] for p in parts)
    mask = np.zeros((row1 - row0, col1 - col0), bool)
    for r, c, part in parts:
        mask[r - row0:r - row0 + part.shape[0], c - col0:c - col0 + part.shape[1]] |= part
    return row0, col0, mask


def activity_windows(events: Iterable) -> dict[str, list[tuple[float, float]]]:
    """{device: [(start, end) s]} of live tool use, from the HAV monitor's events (read duck-typed: ``kind``,
    ``time``, ``source`` = the wearable's device id). An activity not yet ended runs to infinity.

    Args:
        events: The monitor's events (``hav.activity_started`` and ``hav.activity_ended`` are read; others skipped).

    Returns:
        {device: [(start, end)]}, UTC seconds.
    """
    windows: dict[str, list[tuple[float, float]]] = {}
    open_since: dict[str, float] = {}
    for event in sorted(events, key=lambda e: e.time):
        if event.kind == ACTIVITY_STARTED:
            open_since.setdefault(event.source, event.time)
        elif event.kind == ACTIVITY_ENDED and event.source in open_since:
            windows.setdefault(event.source, []).append((open_since.pop(event.source), event.time))
    for device, since in open_since.items():
        windows.setdefault(device, []).append((since, float("inf")))
    return windows


@dataclass(frozen=True)
class WorkerZones:
    """Workers' keep-out circles through the day: ``spots`` {device: (x, y) m} where each worker is (a tag, the
    site plan), ``windows`` when each one's tool runs (``activity_windows``). Call it with a time for the zones
    in force; ``changes`` are the times they change (a navigator's ``zone_changes``)."""

    spots: dict[str, tuple[float, float]]
    windows: dict[str, list[tuple[float, float]]]
    radius: float = WORKER_RADIUS
    live_radius: float = WORKER_LIVE_RADIUS

    def __call__(self, time: float) -> list[KeepOut]:
        return worker_keepouts([(device, xy, self.live(device, time)) for device, xy in self.spots.items()],
                               self.radius, self.live_radius)

    def live(self, device: str, time: float) -> bool:
        """Whether a worker's tool runs at a time.

        Args:
            device: The wearable's device id.
            time: UTC seconds.

        Returns:
            True inside one of the device's activity windows.
        """
        return any(start <= time < end for start, end in self.windows.get(device, ()))

    @property
    def changes(self) -> list[float]:
        """The times (UTC seconds) the zones change: every finite window start and end, earliest first."""
        return sorted({t for device in self.spots for window in self.windows.get(device, ()) for t in window
                       if np.isfinite(t)})
