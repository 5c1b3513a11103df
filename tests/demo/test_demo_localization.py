"""The demo's robot on drifting odometry: with BIM fixes its verdicts match the truth; on dead reckoning alone it
calls objects moved that never moved, and the report says how many."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.bim import load_ifc
from bim2rdt.demo.localization_report import localization_markdown, localization_record, verdict_tally
from bim2rdt.demo.localized import localized_mission
from bim2rdt.demo.perceivers import DemoPerception
from bim2rdt.sim.reality import objects_of_interest
from bim2rdt.sim.site import ROBOT_START_XY
from bim2rdt.mission import MissionConfig, MissionContext, plan_stations
from bim2rdt.semantics import KnowledgeBasePriors
from bim2rdt.sim.meshes import mesh_for_family
from bim2rdt.sim.reality import simulate_reality
from bim2rdt.sim.site import build_site_ifc


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("site")
    model = load_ifc(build_site_ifc(folder / "site.ifc"), cache_dir=folder / "cache")
    targets = objects_of_interest(model)
    reality = simulate_reality(model, [t.global_id for t in targets], seed=0, building=True)
    priors = KnowledgeBasePriors().priors(sorted({t.family for t in reality.truth}))
    stations = plan_stations(targets, ROBOT_START_XY, MissionConfig())
    context = MissionContext(targets, stations, model, priors, mesh_for_family, MissionConfig())
    mission, localization = localized_mission(context,
                                              lambda: DemoPerception("ideal", model, reality, priors, seed=0),
                                              ROBOT_START_XY, seed=0)
    return reality, mission, localization


def test_with_bim_fixes_every_station_is_known_to_a_centimetre_and_no_verdict_is_wrong(runs):
    reality, mission, localization = runs
    assert len(localization.stations) == len(mission.stations)
    assert max(s.error for s in localization.stations) < 0.02
    assert all(s.looks and s.looks[-1].applied for s in localization.stations)
    tally = verdict_tally(mission.observations, reality.truth)
    assert tally == {"right": 11, "false moved": 0, "missed change": 0, "phantom new": 0, "unverified": 0}


def test_on_dead_reckoning_the_drift_makes_unchanged_objects_look_moved(runs):
    reality, _, localization = runs
    errors = [s.error for s in localization.dead_reckoning_stations]
    assert max(errors) > 0.1 and errors[-1] > errors[0]
    assert all(not s.looks for s in localization.dead_reckoning_stations)  # it never looked at the BIM
    assert verdict_tally(localization.dead_reckoning.observations, reality.truth)["false moved"] >= 1


def test_the_report_lists_each_stations_fix_and_check_shots_and_the_dead_reckoning_mistakes(runs):
    reality, mission, localization = runs
    record = localization_record(localization, mission, reality.truth)
    text = localization_markdown(record)
    assert "## Robot localization" in text and "### Check shots" in text
    assert "## The same mission on dead reckoning alone" in text
    false_moved = record["dead_reckoning"]["verdicts"]["false moved"]
    assert f"would report {false_moved} object(s) as moved that never moved" in text
    shots = [shot for row in record["anchored"]["stations"] for shot in row["check_shots"]]
    assert shots and all(shot["residual_m"] < 0.03 and shot["tape_m"] > 0.3 for shot in shots)
    assert np.isfinite([row["error_m"] for row in record["dead_reckoning"]["stations"]]).all()


def test_verdicts_are_judged_per_bim_element_and_a_new_object_by_where_the_unplanned_one_stands():
    from types import SimpleNamespace as Record

    def at(x, y):
        T = np.eye(4)
        T[:2, 3] = (x, y)
        return T

    truth = [Record(global_id="a", change="unchanged", T_world_model=at(0, 0)),
             Record(global_id="b", change="moved", T_world_model=at(5, 0)),
             Record(global_id=None, change="unplanned", T_world_model=at(9, 9))]
    observations = [Record(global_id="a", status="deviating", pose=at(0.2, 0)),
                    Record(global_id="b", status="as planned", pose=at(5, 0)),
                    Record(global_id=None, status="new", pose=at(9.1, 9)),
                    Record(global_id=None, status="new", pose=at(2, 2)),
                    Record(global_id="a", status="unverified", pose=at(0, 0))]
    assert verdict_tally(observations, truth) == {"right": 1, "false moved": 1, "missed change": 1,
                                                  "phantom new": 1, "unverified": 1}
