"""``bim2rdt demo --ifc FILE``: the embedded day's loop on another building.

1. BIM: read the file; slice its ground floor into the robot's map (its own slab height, its doors open).
2. Site: place site objects in free space on that slab, one per room, far rooms first (``sim.furnish``), and
   write them into a copy (``site.ifc``) as proxies: the as-designed site.
3. Reality: the simulator moves some of them, knocks a cone, and leaves a drum nobody planned; the robot's
   camera sees them inside the building (walls occlude) and reads its frames with the day's detector.
4. Safety: the workers' wearables stream through the HAV monitor (their activity windows shape the robot's
   keep-out zones).
5. Robot: stations that see each object over the walls, toured by path length, walked on planned paths room to
   room through the doors, replanned around what it finds and around workers while they work.
6. Twin: for IFC4 the verdicts and the safety records go into ``site_twin.ifc``; IFC2X3 has no IfcEvent or
   IfcTaskTime, so there the twin is not written back (the report says so).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from bim2rdt.bim import load_ifc
from bim2rdt.demo.perceivers import DemoPerception
from bim2rdt.demo.routes import plan_day_route
from bim2rdt.sim.reality import objects_of_interest
from bim2rdt.demo.site_day import SiteDay, _hav_day, _model_cache, _shift_start
from bim2rdt.demo.site_twin import export_day_twin, ifc_records, open_day_twin, record_mission
from bim2rdt.localization import LocalizationConfig
from bim2rdt.perception import PerceptionConfig
from bim2rdt.perception.detectors import check_detector
from bim2rdt.mission import MissionConfig, MissionContext, building_surfaces, run_mission
from bim2rdt.planning import OccupancyGrid, PlanningError
from bim2rdt.registration import IcpConfig
from bim2rdt.semantics import KnowledgeBasePriors
from bim2rdt.sim.furnish import FAMILIES, furnish, write_furnished
from bim2rdt.sim.meshes import mesh_for_family
from bim2rdt.sim.reality import simulate_reality
from bim2rdt.twin import TwinConfig

IFC_DAY_STANDOFF = 2.0
"""Rooms of a house are smaller than a site's open slab: stations stand 2 m back (the camera still sees a
whole pallet at that distance)."""


def run_ifc_day(ifc_path: Path, out_dir: Path, seed: int = 0, workers: int = 1, minutes: float = 10.0,
                fs: float = 5000.0, mission_config: MissionConfig = MissionConfig(), icp: IcpConfig = IcpConfig(),
                twin_config: TwinConfig = TwinConfig(), tick: Callable[[str], None] = lambda stage: None,
                detector: str = "geometric", yoloe: tuple[Path, Path] | None = None,
                objects: int = len(FAMILIES), localization: LocalizationConfig | None = None,
                perception: PerceptionConfig = PerceptionConfig()) -> SiteDay:
    """Run the day on ``ifc_path`` into ``out_dir``: ``site.ifc`` (the building with its planned site objects),
    the day's twin and its exports (``site_twin.ifc`` only for IFC4), and the monitor's state under ``state/``.
    Up to ``objects`` site objects are placed (fewer: fewer stations, a quicker look at the same loop).
    The mission's standoff is capped at ``IFC_DAY_STANDOFF``. The robot's camera sees the building and reads
    its frames with ``detector``, as on the embedded day (:mod:`bim2rdt.demo.perceivers`); an unknown one, or
    ``yoloe`` without its files, is refused before anything is read or written."""
    check_detector(detector, yoloe)
    out_dir.mkdir(parents=True, exist_ok=True)
    source = load_ifc(ifc_path, cache_dir=_model_cache())
    tick("bim")
    layout = furnish(source, OccupancyGrid.from_bim(source).with_zones(source.zones), workers, seed, objects)
    if not layout.objects:
        raise PlanningError(f"{source.path.name}: no free floor reachable from the dock on storey "
                            f"{layout.storey!r} to place site objects on")
    model = load_ifc(write_furnished(source, layout, out_dir / "site.ifc"), cache_dir=_model_cache())
    tick("site")
    targets = objects_of_interest(model)
    reality = simulate_reality(model, [t.global_id for t in targets], seed=seed, unplanned_at=layout.unplanned_xy,
                               building=True)
    priors = KnowledgeBasePriors().priors(sorted({t.family for t in targets} | {t.family for t in reality.truth}))
    twin = open_day_twin(out_dir, model, priors, twin_config)
    events, timeline = _hav_day(twin, out_dir / "state", workers, minutes, fs, zone=None)
    tick("hav")
    config = mission_config.model_copy(update={"standoff": min(mission_config.standoff, IFC_DAY_STANDOFF)})
    route = plan_day_route(model, targets, layout.dock_xy, config, events, _shift_start(), spots=layout.worker_spots)
    perceive = DemoPerception(detector, model, reality, priors, seed, yoloe, config=perception)
    context = MissionContext(targets, route.plan.stations, model, priors, mesh_for_family, route.config, icp,
                             twin_config.tolerance_policy(), twin_config.min_fitness, localization=localization,
                             building=building_surfaces(model), tick=lambda: tick("station"))
    mission = run_mission(context, perceive, route.route, perceive.station_frame)
    record_mission(twin, mission.observations, mission.stations, times=route.route.arrivals, missing=mission.missing)
    tick("twin")
    files = export_day_twin(twin, out_dir)
    return SiteDay(model, priors, reality, mission, files.ifc, events, timeline, ifc_records(files.ifc), twin, files,
                   route)


def run_ifc_demo(ifc_path: Path, out_dir: Path, seed: int = 0, workers: int = 1, minutes: float = 10.0,
                 tick: Callable[[str], None] = lambda stage: None, detector: str = "geometric",
                 yoloe: tuple[Path, Path] | None = None, objects: int = len(FAMILIES)):
    """The ``demo --ifc`` job: the IFC day, its reports (``report.md``, ``report.html``) and the settings that ran
    in ``config.json`` (no registration scenarios: they do not depend on the building)."""
    import json

    from bim2rdt.atomic import write_bytes_atomic
    from bim2rdt.evaluation.runs import versions
    from bim2rdt.config import settings_record
    from bim2rdt.demo.run import DemoResult, _html
    from bim2rdt.demo.settings import demo_settings
    from bim2rdt.demo.site_report import write_site_report

    out_dir, settings = Path(out_dir), demo_settings()
    day = run_ifc_day(Path(ifc_path), out_dir, seed=seed, workers=workers, minutes=minutes,
                      mission_config=settings.mission, icp=settings.registration, twin_config=settings.twin, tick=tick,
                      detector=detector, yoloe=yoloe, objects=objects, localization=settings.localization,
                      perception=settings.perception)
    report = write_site_report(day, out_dir)
    resolved = {"settings": settings_record(settings), "ifc": str(Path(ifc_path).resolve()),
                "schema": day.model.schema, "objects": objects, "seed": seed, "workers": workers, "minutes": minutes,
                "detector": detector,
                "yoloe": [str(p) for p in yoloe] if yoloe else None,
                "mission": day.route.config.model_dump(), "versions": versions()}
    write_bytes_atomic(out_dir / "config.json", json.dumps(resolved, indent=2).encode("utf-8"))
    report["html"] = _html(day, None, out_dir)
    return DemoResult(day, report, None)
