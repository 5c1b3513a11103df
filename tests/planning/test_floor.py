"""The floor the robot walks: its height from the storey's slab (never a constant), its extent, and the errors."""

from __future__ import annotations

import pytest

from bim2rdt.planning import OccupancyGrid, PlanningError
from bim2rdt.planning.floor import find_floor


def test_the_embedded_sites_floor_is_the_top_of_its_slab(site_model):
    floor = find_floor(site_model)
    assert floor.source == "slab" and floor.z == pytest.approx(0.0, abs=1e-6)
    assert floor.storey.name == "Ground Floor"


def test_an_upper_storeys_floor_is_its_own_slab_top_and_the_storey_below_is_not_in_its_grid(building):
    model = building(elevation=0.0, upper=True, objects=[("IfcFurnishingElement", "Crate", (1.0, 1.0, 0.8),
                                                          (2.5, 1.5, 0.0))])
    lower = OccupancyGrid.from_bim(model, storey="Level 0")
    upper = OccupancyGrid.from_bim(model, storey="Level 1")
    assert lower.floor_z == pytest.approx(0.0) and upper.floor_z == pytest.approx(3.2)
    assert not lower.is_free((2.5, 1.5)) and upper.is_free((2.5, 1.5))


def test_a_storey_at_an_elevation_takes_its_floor_from_the_bim_not_a_constant(building):
    grid = OccupancyGrid.from_bim(building(elevation=7.5))
    assert grid.floor_z == pytest.approx(7.5)
    assert grid.z_band == pytest.approx((7.55, 8.7))
    assert grid.is_free((2.5, 3.0)) and not grid.is_free((0.1, 3.0))


def test_without_slabs_the_storeys_spaces_give_the_floor_and_doorways_still_join_the_rooms(building):
    from bim2rdt.planning import plan_path

    grid = OccupancyGrid.from_bim(building(slab=False, space=True, elevation=1.0))
    assert grid.floor_source == "spaces" and grid.floor_z == pytest.approx(1.0)
    assert len(plan_path(grid, (2.0, 3.0), (8.0, 3.0))) >= 2


def test_a_storey_with_no_slab_is_a_one_line_error(building):
    with pytest.raises(PlanningError, match="storey 'Level 0' has no slab") as error:
        OccupancyGrid.from_bim(building(slab=False), storey="Level 0")
    assert "\n" not in str(error.value)
    with pytest.raises(PlanningError, match="no storey has a slab"):
        OccupancyGrid.from_bim(building(slab=False))


def test_an_unknown_storey_names_the_storeys_there_are(building):
    with pytest.raises(PlanningError, match=r"no storey 'Roof' \(storeys: 'Level 0'\)"):
        OccupancyGrid.from_bim(building(), storey="Roof")


def test_a_storey_can_be_given_by_global_id_or_record(building):
    model = building(upper=True)
    by_record = OccupancyGrid.from_bim(model, storey=model.storeys[1])
    by_id = OccupancyGrid.from_bim(model, storey=model.storeys[1].global_id)
    assert by_record.floor_z == by_id.floor_z == pytest.approx(3.2)


def test_the_fzk_house_upper_storey_stands_on_its_own_slab_at_2_7_m(sample_model):
    model = sample_model("AC20-FZK-Haus.ifc")
    assert find_floor(model).storey.name == "Erdgeschoss"
    upper = find_floor(model, "Dachgeschoss")
    assert upper.source == "slab" and upper.z == pytest.approx(2.7, abs=0.01)


def test_office_a_has_no_floor_slabs_so_its_spaces_give_each_storeys_floor(sample_model):
    model = sample_model("Office_A_20110811.ifc")
    ground, first = find_floor(model, "Level 1"), find_floor(model, "Level 2")
    assert ground.source == first.source == "spaces"
    assert ground.z == pytest.approx(0.0, abs=0.01) and first.z == pytest.approx(4.267, abs=0.01)
