"""The robot's route on a demo day: the BIM's map, stations that see their objects over the walls, and the walk,
replanned around what the robot finds and around workers while their tools run.

The workers stand at ``WORKER_SPOTS`` (on a real site their tags would say where); when each one's tool runs
comes from the HAV monitor's events, so the robot's keep-out zones follow the same clock as the exposure
records. The robot leaves its dock ``LEAVES_BEFORE_S`` before the shift's first tool starts, so a worker starts
grinding while it walks.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.demo.plan_map import MapObject, outline, save_plan_map
from bim2rdt.mission import MissionConfig, PlannedRoute, RoutePlan, Target, plan_route
from bim2rdt.planning import Navigator, OccupancyGrid, WorkerZones, activity_windows, path_length

WORKER_SPOTS = {"w1": (9.0, 3.0), "w2": (2.0, 11.5)}
"""Where the embedded site's simulated workers stand, by wearable device: w1 grinds beside column C12, between the
work area and the storage, w2 drills in the north-west corner."""
LEAVES_BEFORE_S = 40.0
UNPLANNED_DRUM_XY = (2.65, 2.46)
"""Where the day's unplanned drum was left: across the robot's first leg from the dock, so it sees the drum
looking ahead and walks round it."""


@dataclass
class DayRoute:
    """The map the robot planned on (the BIM, its off-limits zones), its route plan and walk, the workers' zones
    through the day, and the mission's config with the storey's own slab height."""

    grid: OccupancyGrid
    plan: RoutePlan
    route: PlannedRoute
    workers: WorkerZones
    config: MissionConfig

    @property
    def navigator(self) -> Navigator:
        return self.route.navigator

    def summary(self) -> dict:
        """What the report records: stations, metres walked, replans with their reasons, skipped stations, and
        every leg walked (world metres, the shift's clock)."""
        walked = [leg.path for leg in self.navigator.legs]
        return {"stations": len(self.plan.stations), "visited": len(self.route.arrivals),
                "walked_m": round(sum(path_length(p) for p in walked), 2),
                "minutes": round((self.navigator.time - self.navigator.legs[0].start_time) / 60.0, 1)
                if self.navigator.legs else 0.0,
                "replans": [{"time": r.time, "x": r.xy[0], "y": r.xy[1], "reason": r.reason}
                            for r in self.navigator.replans],
                "skipped": {str(k): v for k, v in self.route.skipped.items()}, "unplaced": self.plan.unplaced,
                "located": sorted(self.route.located),
                "legs": [{"start": leg.start_time, "end": leg.end_time, "replanned": leg.replanned,
                          "path": np.round(leg.path, 4).tolist()} for leg in self.navigator.legs]}


def why_no_station(day_route: DayRoute) -> str | None:
    """Why the robot visited no station (each object's reason, or that there was none to visit); None when it
    visited at least one."""
    if day_route.route.arrivals:
        return None
    reasons = [*day_route.plan.unplaced.values(), *day_route.route.skipped.values()]
    return "; ".join(reasons) if reasons else "no site object to visit"


def plan_day_route(model: BimModel, targets: Sequence[Target], start_xy, config: MissionConfig, hav_events,
                   shift_start: float, spots: dict[str, tuple[float, float]] | None = None) -> DayRoute:
    """The route for a day: stations planned on the BIM's ground floor with its off-limits zones (people move:
    their zones are the navigator's business), the navigator on the shift's clock with the workers' zones from
    the HAV events (``spots`` default to ``WORKER_SPOTS``)."""
    workers = WorkerZones(WORKER_SPOTS if spots is None else spots, activity_windows(hav_events))
    grid = OccupancyGrid.from_bim(model)
    leaves = shift_start - LEAVES_BEFORE_S

    def zones_at(time: float) -> list:
        return [*model.zones, *workers(time)]

    plan = plan_route(targets, start_xy, grid.with_zones(model.zones), config)
    navigator = Navigator(grid, np.asarray(start_xy, float), time=leaves, zones_at=zones_at,
                          zone_changes=workers.changes)
    return DayRoute(grid, plan, PlannedRoute(plan, navigator, config.camera_height), workers,
                    config.model_copy(update={"slab_height": grid.floor_z}))


def draw_walk(ax, day_route: DayRoute, stations: Sequence[np.ndarray]) -> None:
    """The robot's walk on matplotlib axes: legs as planned (blue), replanned (red, dashed), stations numbered."""
    for leg in day_route.navigator.legs:
        style = {"color": "tab:red", "ls": "--"} if leg.replanned else {"color": "tab:blue", "ls": "-"}
        ax.plot(*leg.path.T, lw=1.4, **style)
    ax.plot([], [], color="tab:blue", label="robot path")
    ax.plot([], [], color="tab:red", ls="--", label="replanned")
    for number, T in enumerate(stations, start=1):
        ax.plot(*T[:2, 3], "^", color="tab:blue", ms=6, mec="black", mew=0.5)
        ax.annotate(str(number), T[:2, 3], xytext=(3, 3), textcoords="offset points", fontsize=7)


def save_route_map(day_route: DayRoute, objects: Sequence[MapObject], stations: Sequence[np.ndarray],
                   path: Path, twin_state=None) -> Path:
    """The plan map of the walk (``demo.plan_map``): the robot's final map (walls, margin, off-limits and worker
    zones as they were when it finished; with ``twin_state``, the objects where the twin has them), ``objects`` by
    status, the walk and its stations."""
    navigator = day_route.navigator
    grid = navigator.grid if twin_state is None else navigator.grid.with_obstacles(twin_state)
    return save_plan_map(grid, path, objects=objects, stations=stations,
                         paths=[leg.path for leg in navigator.legs if not leg.replanned],
                         replanned=[leg.path for leg in navigator.legs if leg.replanned],
                         title=f"Robot route: {day_route.summary()['walked_m']} m walked, "
                               f"{len(navigator.replans)} replans")


def known_grid(day, states):
    """What the robot knows at the end of the day as an occupancy grid: the BIM's, with the twin's observed
    objects (``states``) and the off-limits zones (the keep-out mask): the Nav2 map the demo writes and
    publishes."""
    return day.route.grid.with_obstacles(states).with_zones(day.model.zones)


def write_route_files(day, out_dir: Path) -> dict[str, Path]:
    """For a day with a planned route (a ``SiteDay``): ``plan_map.png`` (the robot's map, the objects by their
    twin status, the walk, stations and zones; ``report.html`` shows it) and the Nav2 map of what the robot knows
    at the end of the day (the BIM with the twin's observed objects, the off-limits zones as the keep-out mask)
    in ``nav2/site.*``."""
    from bim2rdt.demo.site_twin import map_outlines

    if day.twin is not None:
        states = day.twin.state()
        objects = [MapObject(o.name, o.outline_xy, o.status, o.planned_xy) for o in map_outlines(day.twin, states)]
    else:
        states, objects = {}, map_objects(day.model, day.mission.observations)
    written = {"plan_map": save_route_map(day.route, objects, day.mission.stations, out_dir / "plan_map.png",
                                          states if day.twin is not None else None)}
    known = known_grid(day, states)
    written.update({f"nav2_{what}": path for what, path in known.save_nav2(out_dir / "nav2", "site").items()})
    return written


def map_objects(model: BimModel, observations) -> list[MapObject]:
    """Map objects from the mission's observations: each body mesh at its measured pose, coloured by status,
    with its BIM outline where it is a BIM element."""
    from bim2rdt.sim.meshes import mesh_for_family
    from bim2rdt.sim.reality import body_mesh

    objects = []
    for obs in observations:
        body = body_mesh(model, obs.global_id).vertices if obs.global_id else mesh_for_family(obs.family).vertices
        planned = model.element(obs.global_id).placement if obs.global_id else None
        objects.append(MapObject(obs.family, _outline(body, obs.pose), str(obs.status),
                                 None if planned is None else _outline(body, planned)))
    return objects


def route_rows(day_route: DayRoute) -> list[tuple[str, str, str]]:
    """(time UTC, where, why) of every replan, for the terminal and report.md."""
    return [(datetime.fromtimestamp(r.time, timezone.utc).strftime("%H:%M:%S"), f"({r.xy[0]:.1f}, {r.xy[1]:.1f})",
             r.reason) for r in day_route.navigator.replans]


def route_markdown(day_route: DayRoute) -> list[str]:
    """The report's section on the robot's route."""
    summary = day_route.summary()
    lines = ["## Robot route", "",
             f"{summary['stations']} stations on planned paths (none through a wall), {summary['walked_m']} m "
             f"walked in {summary['minutes']} min; workers' keep-out zones from the HAV monitor's events "
             f"({len(day_route.workers.changes)} changes in the day).", ""]
    if summary["unplaced"] or summary["skipped"]:
        lines += [f"Not visited: {'; '.join([*summary['unplaced'].values(), *summary['skipped'].values()])}.", ""]
    lines += ["| time (UTC) | at (x, y) m | why the robot replanned |", "|---|---|---|"]
    lines += [f"| {t} | {xy} | {why} |" for t, xy, why in route_rows(day_route)]
    return lines + ["", "![plan map](plan_map.png)", ""]


def _outline(vertices_body: np.ndarray, T_world_model: np.ndarray) -> np.ndarray:
    world = np.asarray(vertices_body) @ T_world_model[:3, :3].T + T_world_model[:3, 3]
    return outline(world[:, :2])
