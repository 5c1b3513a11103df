"""The demo's twin helpers: a fresh twin per day, mission observations recorded with their station cameras, and
plan outlines of what the robot found."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.demo.site_twin import map_outlines, open_day_twin, record_mission
from bim2rdt.perception.camera import look_at
from bim2rdt.perception.observation import Observation
from bim2rdt.semantics import KnowledgeBasePriors
from bim2rdt.sim.site import yaw_pose
from bim2rdt.twin import ElementStatus

T0 = 1_780_000_000.0


def _priors(model):
    return KnowledgeBasePriors().priors(sorted({el.family for el in model.elements if el.family}
                                               | {"Steel_Drum_55gal"}))


def test_a_day_twin_starts_empty_and_records_each_observation_with_its_station_camera(tmp_path, site_model):
    cone = next(el for el in site_model.elements if el.family == "Traffic_Cone_Orange_70cm")
    moved = cone.placement.copy()
    moved[0, 3] += 0.3
    stations = [look_at((1.0, 1.0, 1.1), (3.0, 2.0, 0.3)), look_at((8.0, 6.0, 1.1), (10.0, 8.0, 0.3))]
    observations = [Observation(cone.family, cone.global_id, moved, 0.004, 0.9, 200, station=0, frames=(0,)),
                    Observation("Steel_Drum_55gal", None, yaw_pose(10.0, 8.0, 0.0, 0.0), 0.004, 0.9, 200, station=1)]
    with open_day_twin(tmp_path, site_model, _priors(site_model)) as twin:
        record_mission(twin, observations, stations, T0)
    with open_day_twin(tmp_path, site_model, _priors(site_model)) as twin:
        assert twin.events() == []  # a new day starts from an empty twin
        record_mission(twin, observations, stations, T0)
        states = twin.state()
        assert states[cone.global_id].status is ElementStatus.DEVIATING
        assert np.allclose(states[cone.global_id].evidence.camera, stations[0])
        drum = next(s for s in states.values() if s.status is ElementStatus.NEW)
        assert drum.evidence.time == pytest.approx(T0 + 30.0) and np.allclose(drum.evidence.camera, stations[1])
        outlines = {o.status: o for o in map_outlines(twin, states)}
    assert set(outlines) == {"deviating", "new"}
    cone_outline = outlines["deviating"]
    assert np.allclose(cone_outline.outline_xy.mean(axis=0) - cone_outline.planned_xy.mean(axis=0), (0.3, 0.0),
                       atol=0.02)
    assert outlines["new"].planned_xy is None
    assert np.allclose(outlines["new"].outline_xy.mean(axis=0), (10.0, 8.0), atol=0.05)


def test_the_page_links_the_files_present_and_prefers_the_planner_s_map(tmp_path):
    from bim2rdt.demo.day_html import present_links

    for name in ("site_twin.ifc", "site_issues.bcf", "nav2/site.yaml"):
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text("x")
    assert present_links(tmp_path) == {"twin IFC (as built)": "site_twin.ifc", "BCF issues": "site_issues.bcf",
                                       "Nav2 map": "nav2/site.yaml"}
