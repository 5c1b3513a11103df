"""The demo robot's eyes: frames rendered inside the building, read by the chosen detector; what the mission gets."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.bim import load_ifc
from bim2rdt.demo.perceivers import DemoPerception
from bim2rdt.sim.reality import objects_of_interest
from bim2rdt.sim.site import ROBOT_START_XY
from bim2rdt.mission import MissionConfig, plan_stations
from bim2rdt.perception import PerceptionError
from bim2rdt.semantics import KnowledgeBasePriors
from bim2rdt.sim.reality import simulate_reality
from bim2rdt.sim.scene import STRUCTURE
from bim2rdt.sim.site import build_site_ifc


@pytest.fixture(scope="module")
def day(tmp_path_factory):
    folder = tmp_path_factory.mktemp("demo-site")
    model = load_ifc(build_site_ifc(folder / "site.ifc"), cache_dir=folder / "cache")
    targets = objects_of_interest(model)
    reality = simulate_reality(model, [t.global_id for t in targets], seed=0, building=True)
    priors = KnowledgeBasePriors().priors(sorted({t.family for t in reality.truth}))
    return model, reality, priors, plan_stations(targets, ROBOT_START_XY, MissionConfig())


@pytest.mark.parametrize("detector", ["geometric", "ideal"])
def test_each_station_gives_named_detections_with_world_points_on_their_objects(day, detector):
    model, reality, priors, stations = day
    perceive = DemoPerception(detector, model, reality, priors, seed=0)
    for station in (0, 5):
        detections = perceive(station, stations[station])
        assert detections and all(d.station == station and d.family != "unknown" for d in detections)
        for d in detections:
            true = [t for t in reality.truth if t.family == d.family]
            nearest = min(np.linalg.norm(np.median(d.points_world, axis=0)[:2] - t.T_world_model[:2, 3]) for t in true)
            assert nearest < 1.0 and len(d.points_world) >= 12
    assert (perceive.frames[-1].labels == STRUCTURE).any()  # the building is in the robot's view


def test_yoloe_without_local_files_is_a_one_line_error(day):
    model, reality, priors, _ = day
    with pytest.raises(PerceptionError, match="--yoloe-weights"):
        DemoPerception("yoloe", model, reality, priors)
