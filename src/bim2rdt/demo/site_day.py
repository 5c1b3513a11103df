"""One simulated day on the embedded site, end to end: the loop of the BIM2RDT paper.

1. BIM: build the default site (IFC4) and read it; its proxies are the objects of interest.
2. Semantics: family names -> detector labels and upright priors (offline knowledge base).
3. Robot: the as-built site (objects moved, one knocked over, one taken away, one unplanned) is seen from
   stations that see their objects over the walls, toured by path length and walked on planned paths,
   replanned around what the robot finds and around workers while their tools run (:mod:`bim2rdt.demo.routes`),
   on drifting odometry with a fix on the BIM after each walk (:mod:`bim2rdt.demo.localized`); corners in each
   detection become points placed from that estimate; SG-ICP registers each BIM object; deviations are judged;
   a planned object whose place a station's depth shows empty is missing.
4. Twin: every observation is recorded into the day's twin (``twin.db``, :mod:`bim2rdt.demo.site_twin`), which
   judges it against its tolerance preset.
5. Safety (run first, so the robot's keep-out zones follow the monitor's events): wearables stream hand-arm
   vibration through the bus into the ISO 5349-1 monitor; its events go into the twin's history.
6. The twin is exported: ``site_twin.ifc`` (moved objects at their measured placement, unplanned ones as proxies,
   activity starts and ends and EAV/ELV crossings as IfcEvent/IfcTask on the work zone), the BCF issues and the
   JSON state; the caller writes the report.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bim2rdt.bim import BimModel, load_ifc
from bim2rdt.demo.day_structure import judge_day_structure
from bim2rdt.demo.localized import MissionLocalization, localized_mission
from bim2rdt.demo.routes import UNPLANNED_DRUM_XY, DayRoute, plan_day_route
from bim2rdt.demo.site_twin import TwinFiles, export_day_twin, ifc_records, open_day_twin, record_mission
from bim2rdt.localization import LocalizationConfig
from bim2rdt.perception import PerceptionConfig
from bim2rdt.mission import MissionConfig, MissionContext, MissionResult
from bim2rdt.registration import IcpConfig
from bim2rdt.semantics import KnowledgeBasePriors, UprightPrior
from bim2rdt.sim.meshes import mesh_for_family
from bim2rdt.demo.perceivers import DemoPerception
from bim2rdt.sim.reality import Reality, objects_of_interest, simulate_reality
from bim2rdt.sim.site import ROBOT_START_XY, ZONES, build_site_ifc
from bim2rdt.structure import StructureConfig, StructureJudgement
from bim2rdt.twin import DigitalTwin, ProgressFiles, TwinConfig

WORK_ZONE = ZONES[0][0]
REMOVED_OBJECTS = 1
"""Planned objects the day's reality takes off the site (the last unchanged one: the tripod at seed 0): the
robot must see their places empty and report them missing."""


@dataclass
class SiteDay:
    """Everything the day produced, for the report."""

    model: BimModel
    priors: dict[str, UprightPrior]
    reality: Reality
    mission: MissionResult
    twin_path: Path | None
    hav_events: list
    exposure_timeline: list[tuple[float, str, float]]
    twin_records: list[tuple[str, str]]
    twin: DigitalTwin | None = None
    twin_files: TwinFiles | None = None
    route: DayRoute | None = None
    localization: MissionLocalization | None = None  # the robot's fixes, and the dead-reckoning comparison run
    odometry: list[tuple[float, np.ndarray]] | None = None
    """Each capture's (time, T_odom_camera) on the robot's clock, as ``--record`` writes them (kept with
    ``record`` or ``keep_odometry``)."""
    structure: list[StructureJudgement] = field(default_factory=list)
    """Each permanent element's judgement (``structure.json``, :mod:`bim2rdt.demo.day_structure`)."""
    progress: ProgressFiles | None = None
    """The day's progress against the site's work schedule (:mod:`bim2rdt.demo.progress`; None before it is
    written, or without a schedule)."""


def run_site_day(out_dir: Path, seed: int = 0, workers: int = 2, minutes: float = 60.0, fs: float = 5000.0,
                 mission_config: MissionConfig = MissionConfig(), icp: IcpConfig = IcpConfig(),
                 twin_config: TwinConfig = TwinConfig(),
                 tick: Callable[[str], None] = lambda stage: None, detector: str = "geometric",
                 yoloe: tuple[Path, Path] | None = None, record: Path | None = None,
                 max_targets: int | None = None, keep_odometry: bool = False,
                 localization: LocalizationConfig | None = None,
                 perception: PerceptionConfig = PerceptionConfig(),
                 structure_config: StructureConfig = StructureConfig()) -> SiteDay:
    """Run the day into ``out_dir``: ``site.ifc`` (as designed), the day's twin (``twin.db``) and its exports
    (``site_twin.ifc`` as built with safety records, ``site_issues.bcf``, ``twin.json``), and the monitor's state
    under ``state/`` (both started afresh: the demo simulates a new day). The mission runs with
    ``mission_config`` and registers with ``icp``; the twin judges with ``twin_config``'s presets (the demo passes
    ``Settings.mission``, ``Settings.registration`` and ``Settings.twin``). The robot's camera sees the building
    and reads its frames with ``detector`` (:mod:`bim2rdt.demo.perceivers`). ``record``: also write the robot's run
    as a ROS 2 bag there (:mod:`bim2rdt.demo.record`); ``max_targets``: stations for the first N site objects only (a
    short day; what they see of the others is judged too); ``keep_odometry``: keep the robot's odometry at each
    capture (``SiteDay.odometry``) without a bag. ``localization`` and ``perception``: the robot's BIM fixes and
    its perception front end (the demo passes ``Settings.localization`` and ``Settings.perception``)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    model = load_ifc(build_site_ifc(out_dir / "site.ifc"), cache_dir=_model_cache())
    tick("bim")
    planned = objects_of_interest(model)
    reality = simulate_reality(model, [t.global_id for t in planned], seed=seed, unplanned_at=UNPLANNED_DRUM_XY,
                               building=True, removed=REMOVED_OBJECTS)
    targets = planned[:max_targets]  # the site changes as on a full day; the robot's stations face these objects
    priors = KnowledgeBasePriors().priors(sorted({t.family for t in planned} | {t.family for t in reality.truth}))
    twin = open_day_twin(out_dir, model, priors, twin_config)
    events, timeline = _hav_day(twin, out_dir / "state", workers, minutes, fs)
    tick("hav")

    def route_for_today() -> DayRoute:
        return plan_day_route(model, targets, ROBOT_START_XY, mission_config, events, _shift_start())

    perceivers: list[DemoPerception] = []  # the day's camera: its station frames judge the structure too

    def eyes() -> DemoPerception:
        perceivers.append(DemoPerception(detector, model, reality, priors, seed, yoloe, config=perception))
        return perceivers[-1]

    route = route_for_today()
    # every planned object is a target: one the short day's stations see by chance is that element, not a new one
    context = MissionContext(planned, route.plan.stations, model, priors, mesh_for_family, route.config, icp,
                             twin_config.tolerance_policy(), twin_config.min_fitness, localization=localization,
                             tick=lambda: tick("station"))
    recorded: list = []
    with _recorder(record, keep_odometry, recorded) as recording:
        mission, localization = localized_mission(context, eyes, ROBOT_START_XY, seed, route=route.route,
                                                  comparison_route=route_for_today().route, record=recording)
    record_mission(twin, mission.observations, mission.stations, times=route.route.arrivals, missing=mission.missing)
    frames = {index: perceivers[0].station_frame(index) for index in range(len(mission.stations))}
    structure = judge_day_structure(model, frames, route.route.arrivals or {}, twin, out_dir, structure_config)
    tick("twin")
    files = export_day_twin(twin, out_dir)
    return SiteDay(model, priors, reality, mission, files.ifc, events, timeline, ifc_records(files.ifc), twin, files,
                   route, localization, recorded[0].captures if recorded else None, structure)


@contextmanager
def _recorder(path: Path | None, keep_odometry: bool, robots: list):
    """None, or ``record(robot, dock)`` wrapping the robot in a :class:`~bim2rdt.demo.record.RecordingRobot`
    (appended to ``robots``) that writes the bag at ``path`` (closed, and renamed into place, when the run ends),
    or with ``keep_odometry`` and no ``path`` only keeps its odometry."""
    if path is None and not keep_odometry:
        yield None
        return
    from bim2rdt.demo.record import RecordingRobot
    from bim2rdt.sources.bag_writer import BagWriter

    def recording(bag):
        def wrap(robot, dock):
            robots.append(RecordingRobot(robot, bag, dock, _shift_start()))
            return robots[-1]
        return wrap

    if path is None:
        yield recording(None)
        return
    with BagWriter(path) as bag:
        yield recording(bag)


def _hav_day(twin: DigitalTwin, state_dir: Path, workers: int, minutes: float, fs: float,
             zone: str | None = WORK_ZONE):
    """Simulated wearables -> in-process bus -> monitor -> events into the twin's history; the workers work in
    ``zone`` (a zone name of the model, or None)."""
    from bim2rdt.bus import LocalBus
    from bim2rdt.demo.settings import demo_settings
    from bim2rdt.safety import HavMonitor, ListSink
    from bim2rdt.sim.wearables import default_plans, publish_plans
    from bim2rdt.twin import TwinSink

    shutil.rmtree(state_dir, ignore_errors=True)
    settings = demo_settings()  # what config.json records: the demo's raw retention unless the environment sets one
    events = ListSink()
    monitor = HavMonitor(state_dir, settings.hav.site_secret, [events, TwinSink(twin)],
                         settings.hav.monitor_config(keep_timeline=True, store_url=None))  # its own folder
    bus = LocalBus().connect()
    monitor.attach(bus)
    publish_plans(lambda device: bus, default_plans(workers, minutes, zone), settings.mqtt.site, fs,
                  t0=_shift_start())
    monitor.close()
    return events.events, list(monitor.queries.timeline)


def _model_cache() -> Path | None:
    """The settings' model cache folder: the site is rebuilt byte-identical each run, so its meshes are cached."""
    from bim2rdt.config import get_settings, ifc_cache_dir

    return ifc_cache_dir(get_settings())


def _shift_start() -> float:
    """07:00 UTC today, Unix seconds: when the simulated shift starts."""
    from datetime import datetime, timezone

    now = datetime.now(timezone.utc)
    return now.replace(hour=7, minute=0, second=0, microsecond=0).timestamp()
