"""The global search on a two-storey model (the planning tests' two rooms, the same plan 3.2 m apart): every
storey is searched, each at its own floor height, and ``storey=`` keeps the search to one."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from bim2rdt.bim import load_ifc
from bim2rdt.localization import find_pose
from bim2rdt.perception import look_at
from bim2rdt.sim.building import building_scene
from bim2rdt.sim.tour import render_frame


def _two_rooms():
    path = Path(__file__).parents[1] / "planning" / "planning_buildings.py"
    spec = importlib.util.spec_from_file_location("planning_buildings_for_localization", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.two_rooms


@pytest.fixture(scope="module")
def upper_view(tmp_path_factory):
    folder = tmp_path_factory.mktemp("storeys")
    model = load_ifc(_two_rooms()(folder / "two.ifc", upper=True), cache_dir=folder / "cache")
    T_true = look_at((2.0, 1.5, 3.2 + 1.1), (0.2, 5.8, 3.2 + 0.8))  # the upper west room, towards its NW corner
    frame = render_frame(building_scene(model), T_true, np.random.default_rng(0))
    return model, frame, T_true


def test_every_storey_is_searched_at_its_own_floor_height(upper_view):
    model, frame, T_true = upper_view
    candidates = find_pose(frame, model)
    storeys = {c.storey for c in candidates}
    assert storeys == {"Level 0", "Level 1"}  # the same plan on both: the view fits on each
    for c in candidates:
        floor = 0.0 if c.storey == "Level 0" else 3.2
        assert c.pose[2, 3] == pytest.approx(floor + 1.1, abs=0.05)  # the height from the floor


def test_one_storey_is_searched_when_named(upper_view):
    model, frame, T_true = upper_view
    candidates = find_pose(frame, model, storey="Level 1")
    assert {c.storey for c in candidates} == {"Level 1"}
    assert any(np.linalg.norm(c.pose[:3, 3] - T_true[:3, 3]) < 0.05 for c in candidates if c.refined)
