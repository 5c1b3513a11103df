"""Planning on real IFC files from other tools: room to room through doors, multi-storey, a big office."""

from __future__ import annotations

import pytest

from bim2rdt.planning import OccupancyGrid, PlanningError, path_length, plan_path

from path_checks import samples_free, segments_through, wall_mesh

pytestmark = pytest.mark.samples

# FZK-Haus ground floor: (2, 2) the living room, (9, 8) the north-east room behind the door Innentuer-1, (3, 8) the
# north-west room behind Innentuer-3.
LIVING, NORTH_EAST, NORTH_WEST = (2.0, 2.0), (9.0, 8.0), (3.0, 8.0)


def test_the_robot_walks_the_fzk_house_room_to_room_through_its_doors(sample_model):
    model = sample_model("AC20-FZK-Haus.ifc")
    grid = OccupancyGrid.from_bim(model)
    assert grid.storey == "Erdgeschoss" and len(grid.open_doors) == 5
    walls = wall_mesh(model)
    for start, goal in ((LIVING, NORTH_EAST), (NORTH_EAST, NORTH_WEST)):
        path = plan_path(grid, start, goal)
        assert segments_through(walls, path) == [] and samples_free(grid, path)
        assert path_length(path) > 1.05 * float(((goal[0] - start[0]) ** 2 + (goal[1] - start[1]) ** 2) ** 0.5)


def test_with_its_doors_closed_the_fzk_rooms_are_cut_off_and_the_error_names_a_door(sample_model):
    grid = OccupancyGrid.from_bim(sample_model("AC20-FZK-Haus.ifc"), doors="closed")
    with pytest.raises(PlanningError, match=r"blocked by Innentuer-\d \(IfcDoor\)"):
        plan_path(grid, LIVING, NORTH_WEST)


def test_the_fzk_attic_is_planned_at_its_own_floor_under_its_sloping_roof(sample_model):
    grid = OccupancyGrid.from_bim(sample_model("AC20-FZK-Haus.ifc"), storey="Dachgeschoss")
    assert grid.floor_z == pytest.approx(2.7, abs=0.01)
    assert grid.is_free((6.0, 5.0))            # under the ridge
    assert not grid.is_free((6.0, 0.9))        # the eaves come down into the robot's band
    assert any(fp.global_id and "Dach" in fp.name for fp in grid.footprints)


def test_office_a_builds_a_grid_from_its_spaces_and_plans_across_it(sample_model):
    grid = OccupancyGrid.from_bim(sample_model("Office_A_20110811.ifc"))
    assert grid.storey == "Level 1" and grid.floor_source == "spaces"
    assert sum(fp.kind == "element" for fp in grid.footprints) > 200
    path = plan_path(grid, (5.0, -5.0), (25.0, -10.0))
    assert samples_free(grid, path)


def test_an_ifc2x3_duplex_storey_plans_on_its_slab(sample_model):
    grid = OccupancyGrid.from_bim(sample_model("Duplex_A_20110907.ifc"), storey="Level 1")
    assert grid.floor_source == "slab" and grid.floor_z == pytest.approx(0.0, abs=0.03)
