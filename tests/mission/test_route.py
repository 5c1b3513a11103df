"""plan_route: each object gets a station the robot can stand on, reach and see it from over the walls, and the
stations are toured by path length."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.bim import load_ifc
from bim2rdt.sim.reality import objects_of_interest
from bim2rdt.sim.site import ROBOT_START_XY
from bim2rdt.mission import MissionConfig, plan_route
from bim2rdt.mission.stations import plan_stations
from bim2rdt.planning import OccupancyGrid, line_of_sight, path_length, reachable
from bim2rdt.sim.site import build_site_ifc


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    folder = tmp_path_factory.mktemp("route-site")
    model = load_ifc(build_site_ifc(folder / "site.ifc"), cache_dir=folder / "cache")
    return model, objects_of_interest(model)


def test_every_station_is_free_reachable_and_sees_its_object(site):
    model, targets = site
    grid = OccupancyGrid.from_bim(model).with_zones(model.zones)
    plan = plan_route(targets, ROBOT_START_XY, grid, MissionConfig())
    assert plan.unplaced == {} and len(plan.stations) == len(targets)
    region = reachable(grid, ROBOT_START_XY)
    for T, target in zip(plan.stations, plan.targets):
        assert region[grid.frame.cell_of(T[:2, 3])]
        assert line_of_sight(grid, T[:2, 3], target.placement[:2, 3], ignore=[target.global_id])
        assert np.linalg.norm(T[:2, 3] - target.placement[:2, 3]) <= 1.4 * MissionConfig().standoff * 1.3


def test_the_old_straight_line_stations_include_some_that_are_blocked_or_hidden(site):
    """What plan_route fixes: the map-blind stations stand in keep-out zones or behind walls."""
    model, targets = site
    grid = OccupancyGrid.from_bim(model).with_zones(model.zones)
    blind = plan_stations(targets, ROBOT_START_XY, MissionConfig())
    bad = [T for T in blind if not grid.is_free(T[:2, 3])]
    assert bad


def test_the_legs_join_the_dock_and_the_stations_in_order_through_free_space(site):
    model, targets = site
    grid = OccupancyGrid.from_bim(model).with_zones(model.zones)
    plan = plan_route(targets, ROBOT_START_XY, grid, MissionConfig())
    here = np.asarray(ROBOT_START_XY)
    for leg, T in zip(plan.legs, plan.stations):
        assert np.allclose(leg[0], here) and np.allclose(leg[-1], T[:2, 3])
        here = T[:2, 3]
    assert sum(path_length(leg) for leg in plan.legs) < 80.0


def test_an_object_behind_a_closed_door_is_reported_not_visited(site):
    model, targets = site
    grid = OccupancyGrid.from_bim(model, doors="closed").with_zones(model.zones)
    plan = plan_route(targets, ROBOT_START_XY, grid, MissionConfig())
    scaffold = next(t for t in targets if t.family.startswith("Scaffold"))
    assert scaffold.global_id in plan.unplaced and "no free, reachable viewpoint" in plan.unplaced[scaffold.global_id]
    assert scaffold not in plan.targets
