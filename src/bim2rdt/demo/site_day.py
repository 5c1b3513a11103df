"""One simulated day on the embedded site, end to end: the loop of the BIM2RDT paper.

1. BIM: build the default site (IFC4) and read it; its proxies are the objects of interest.
2. Semantics: family names -> detector labels and upright priors (offline knowledge base).
3. Robot: the as-built site (objects moved, one knocked over, one unplanned) is seen from planned stations;
   corners in each detection become points; SG-ICP registers each BIM object; deviations are judged.
4. Twin: moved objects get their measured placement, unplanned ones become proxies with an observation pset.
5. Safety: wearables stream hand-arm vibration through the bus into the ISO 5349-1 monitor; activity starts and
   ends, EAV/ELV crossings become IfcEvent/IfcTask records linked to the work zone.
6. The twin is saved atomically; the caller writes the report.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bim2rdt.bim import BimModel, TwinWriter, load_ifc
from bim2rdt.demo.localized import MissionLocalization, localized_mission
from bim2rdt.mission import MissionConfig, MissionResult, Observation, Target, plan_stations
from bim2rdt.semantics import KnowledgeBasePriors, UprightPrior
from bim2rdt.sim.meshes import mesh_for_family
from bim2rdt.sim.reality import Reality, body_mesh, simulate_reality
from bim2rdt.sim.site import ZONES, build_site_ifc

ROBOT_START_XY = (1.0, 1.0)
"""Where the robot's dock is on the default site, metres."""
WORK_ZONE = ZONES[0][0]


@dataclass
class SiteDay:
    """Everything the day produced, for the report."""

    model: BimModel
    priors: dict[str, UprightPrior]
    reality: Reality
    mission: MissionResult
    twin_path: Path
    hav_events: list
    exposure_timeline: list[tuple[float, str, float]]
    twin_records: list[tuple[str, str]]
    localization: MissionLocalization | None = None  # the robot's fixes, and the dead-reckoning comparison run


def objects_of_interest(model: BimModel) -> list[Target]:
    """The site objects the robot verifies: proxies (temporary works, materials, equipment) with a body."""
    return [Target(el.global_id, el.family or el.name or el.ifc_class, el.placement, body_mesh(model, el.global_id))
            for el in model.elements if el.ifc_class == "IfcBuildingElementProxy" and model.has_mesh(el.global_id)]


def run_site_day(out_dir: Path, seed: int = 0, workers: int = 2, minutes: float = 60.0, fs: float = 5000.0,
                 mission_config: MissionConfig = MissionConfig(),
                 tick: Callable[[str], None] = lambda stage: None) -> SiteDay:
    """Run the day into ``out_dir``: ``site.ifc`` (as designed), ``site_twin.ifc`` (as built, with safety
    records) and the monitor's state under ``state/`` (started afresh: the demo simulates a new day)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    model = load_ifc(build_site_ifc(out_dir / "site.ifc"))
    tick("bim")
    targets = objects_of_interest(model)
    reality = simulate_reality(model, [t.global_id for t in targets], seed=seed, building=True)
    priors = KnowledgeBasePriors().priors(sorted({t.family for t in reality.truth}))
    stations = plan_stations(targets, ROBOT_START_XY, mission_config)
    mission, localization = localized_mission(targets, stations, reality, model, priors, mesh_for_family,
                                              mission_config, ROBOT_START_XY, seed, tick=lambda: tick("station"))
    writer = TwinWriter(model)
    apply_observations(writer, mission.observations)
    tick("twin")
    events, timeline, records = _hav_day(writer, model, out_dir / "state", workers, minutes, fs)
    tick("hav")
    twin_path = writer.save(out_dir / "site_twin.ifc")
    return SiteDay(model, priors, reality, mission, twin_path, events, timeline, records, localization)


def apply_observations(writer: TwinWriter, observations: list[Observation]) -> dict[str, str]:
    """Write verdicts into the twin: moved objects get their measured placement, new ones become proxies.
    Returns {observation index: GlobalId} of the new proxies."""
    added = {}
    for index, obs in enumerate(observations):
        if obs.status == "moved":
            writer.move_element(obs.global_id, obs.pose)
        elif obs.status == "new":
            mesh = mesh_for_family(obs.family)
            added[str(index)] = writer.add_object(obs.family, np.asarray(mesh.vertices), np.asarray(mesh.faces),
                                                  obs.pose, properties=_observation_properties(obs))
    return added


def _observation_properties(obs: Observation) -> dict:
    return {"Status": obs.status, "Fitness": float(obs.fit.fitness), "RmseMetres": float(obs.fit.rmse),
            "ScenePoints": int(obs.points), "UprightBias": float(obs.upright_bias), "TiltDegrees": float(obs.tilt_deg),
            "Station": int(obs.station)}


def _hav_day(writer: TwinWriter, model: BimModel, state_dir: Path, workers: int, minutes: float, fs: float):
    """Simulated wearables -> in-process bus -> monitor -> IFC records on ``writer``."""
    from bim2rdt.bus import LocalBus
    from bim2rdt.config import get_settings
    from bim2rdt.safety import HavMonitor, ListSink
    from bim2rdt.safety.ifc_sink import IfcSink
    from bim2rdt.safety.setup import monitor_config
    from bim2rdt.sim.wearables import default_plans, publish_plans

    shutil.rmtree(state_dir, ignore_errors=True)
    settings = get_settings()
    events, ifc_sink = ListSink(), IfcSink(writer, model)
    monitor = HavMonitor(state_dir, settings.hav.site_secret, [events, ifc_sink],
                         monitor_config(settings, keep_timeline=True))
    bus = LocalBus().connect()
    monitor.attach(bus)
    publish_plans(lambda device: bus, default_plans(workers, minutes, WORK_ZONE), settings.mqtt.site, fs,
                  t0=_shift_start())
    monitor.close()
    return events.events, list(monitor.timeline), list(ifc_sink.records)


def _shift_start() -> float:
    """07:00 UTC today, Unix seconds: when the simulated shift starts."""
    from datetime import datetime, timezone

    now = datetime.now(timezone.utc)
    return now.replace(hour=7, minute=0, second=0, microsecond=0).timestamp()
