"""The occupancy grid: what the BIM blocks, doors by policy, the robot's radius, observed objects and zones."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
import trimesh

from bim2rdt.planning import KeepOut, OccupancyGrid, PlanningError, worker_keepouts
from bim2rdt.planning.inflation import inflate
from bim2rdt.sim.site import yaw_pose
from bim2rdt.twin import ElementStatus


@dataclass
class Seen:
    """A stand-in of the twin's per-element state (the duck type planning reads)."""

    pose: np.ndarray | None
    status: ElementStatus = ElementStatus.DEVIATING
    mesh: trimesh.Trimesh | None = None
    family: str | None = None


def drum():
    return trimesh.creation.cylinder(radius=0.3, height=0.9, transform=trimesh.transformations.translation_matrix((0, 0, 0.45)))


def element(model, name):
    return next(el for el in model.elements if el.name == name)


def test_walls_and_columns_are_occupied_and_the_room_between_them_is_free(site_grid):
    assert not site_grid.is_free((6.0, 5.0))          # column C11 (400 mm square at 6, 5)
    assert site_grid.occupied[site_grid.frame.cell_of((6.1, 5.1))]
    assert site_grid.occupied[site_grid.frame.cell_of((10.0, 0.15))]  # inside the south wall
    assert site_grid.is_free((9.0, 8.0))
    assert site_grid.floor_source == "slab" and site_grid.storey == "Ground Floor"


def test_the_robot_radius_keeps_its_centre_that_far_from_every_obstacle(site_grid):
    """The column C11 spans x 5.8..6.2; the robot (0.35 m) may stand 0.35 m off its face, not 0.25 m."""
    assert not site_grid.is_free((6.2 + 0.25, 5.0))
    assert site_grid.is_free((6.2 + 0.35 + 0.06, 5.0))
    bare = OccupancyGrid.from_bim(site_grid.model, robot_radius=0.0)
    assert bare.is_free((6.2 + 0.1, 5.0))


def test_an_open_door_leaves_its_opening_free_and_a_closed_one_fills_it(building):
    model = building()
    doorway = (5.0, 3.0)
    assert OccupancyGrid.from_bim(model).is_free(doorway)
    assert OccupancyGrid.from_bim(model).open_doors == ("Door D1",)
    assert not OccupancyGrid.from_bim(model, doors="closed").is_free(doorway)
    door = element(model, "Door D1")
    assert not OccupancyGrid.from_bim(model, doors=[door.global_id]).is_free(doorway)
    assert not OccupancyGrid.from_bim(model, doors=["Door D1"]).is_free(doorway)
    assert OccupancyGrid.from_bim(model, doors=["another door"]).is_free(doorway)


def test_an_opening_without_a_door_is_a_gap_in_its_wall(building):
    grid = OccupancyGrid.from_bim(building(door=False), doors="closed")
    assert grid.is_free((5.0, 3.0)) and not grid.is_free((5.0, 1.0))


def test_outside_the_slab_is_no_floor_and_blocked(building):
    grid = OccupancyGrid.from_bim(building(), robot_radius=0.0)
    edge = next(fp for fp in grid.footprints if fp.kind == "floor edge")
    assert edge.mask[grid.frame.cell_of((-0.1, 3.0))] and not grid.is_free((-0.1, 3.0))


def test_a_new_object_blocks_where_the_twin_saw_it(site_grid):
    where = (9.0, 8.0)
    grid = site_grid.with_obstacles({"drum-1": Seen(yaw_pose(*where, 0.0, 0.0), ElementStatus.NEW, drum())})
    assert not grid.is_free(where) and site_grid.is_free(where)
    assert [fp.label for fp in grid.objects] == ["drum-1 (observed object)"]


def test_a_moved_bim_element_frees_its_bim_place_and_blocks_its_new_one(site_grid, site_model):
    crate = element(site_model, "Wooden_Crate_1200x800x600 #6")
    moved = crate.placement.copy()
    moved[:2, 3] += (0.0, -2.0)
    grid = site_grid.with_obstacles({crate.global_id: Seen(moved)})
    assert not site_grid.is_free(crate.position[:2]) and grid.is_free(crate.position[:2])
    assert not grid.is_free(moved[:2, 3])


def test_a_missing_element_frees_its_place_and_a_not_observed_one_keeps_it(site_grid, site_model):
    crate = element(site_model, "Wooden_Crate_1200x800x600 #6")
    assert site_grid.with_obstacles({crate.global_id: Seen(None, ElementStatus.MISSING)}).is_free(crate.position[:2])
    kept = site_grid.with_obstacles({crate.global_id: Seen(None, ElementStatus.NOT_OBSERVED)})
    assert not kept.is_free(crate.position[:2])


def test_each_update_replaces_the_observed_objects_and_equals_a_full_recomputation(site_grid, site_model):
    crate = element(site_model, "Wooden_Crate_1200x800x600 #6")
    moved = crate.placement.copy()
    moved[:2, 3] = (10.5, 3.0)
    first = site_grid.with_obstacles({"drum": Seen(yaw_pose(9.0, 8.0, 0.0, 0.0), ElementStatus.NEW, drum()),
                                      crate.global_id: Seen(moved)})
    second = first.with_obstacles({"drum": Seen(yaw_pose(3.0, 9.0, 0.0, 0.0), ElementStatus.NEW, drum())})
    assert second.is_free((9.0, 8.0)) and not second.is_free((3.0, 9.0))
    assert not second.is_free(crate.position[:2]) and second.is_free((10.5, 3.0))
    for grid in (first, second):
        union = np.zeros(grid.frame.shape, bool)
        for fp in grid.footprints:
            union[fp.window] |= fp.mask
        assert np.array_equal(grid.occupied, union)
        assert np.array_equal(grid.blocked, inflate(union, grid.reach))


def test_observations_may_be_a_list_of_records_naming_their_element(site_grid, site_model):
    crate = element(site_model, "Wooden_Crate_1200x800x600 #6")

    @dataclass
    class Observed:
        global_id: str
        pose: np.ndarray

    moved = crate.placement.copy()
    moved[:2, 3] = (10.5, 3.0)
    assert not site_grid.with_obstacles([Observed(crate.global_id, moved)]).is_free((10.5, 3.0))


def test_a_new_object_without_a_mesh_or_with_a_bad_pose_is_a_one_line_error(site_grid):
    with pytest.raises(PlanningError, match="observed object drum: not a BIM element and no mesh"):
        site_grid.with_obstacles({"drum": Seen(np.eye(4), ElementStatus.NEW)})
    with pytest.raises(PlanningError, match="pose must be a finite 4x4"):
        site_grid.with_obstacles({"drum": Seen(np.eye(3), ElementStatus.NEW, drum())})


def test_off_limits_bim_zones_keep_the_robot_out_and_other_zones_do_not(site_grid, site_model):
    grid = site_grid.with_zones(site_model.zones)
    assert [fp.label for fp in grid.zones] == ["Exclusion Zone - Material Storage (keep-out zone)"]
    assert not grid.is_free((17.5, 4.0)) and site_grid.is_free((17.5, 4.0))
    assert grid.is_free((4.5, 4.0))                     # inside the work zone, which is not off-limits
    assert not grid.is_free((14.0 - 0.3, 3.0))          # the robot's body stays out too


def test_workers_keep_the_robot_further_away_while_their_tool_runs():
    idle, live = worker_keepouts([("w1", (5.0, 5.0), False), ("w2", (9.0, 9.0), True)])
    assert idle.radius < live.radius and idle.kind == live.kind == "person"


def test_a_worker_circle_blocks_around_them_and_moves_with_them(site_grid):
    grid = site_grid.with_zones(worker_keepouts([("w1", (8.5, 8.0), True)]))
    assert not grid.is_free((8.5, 8.0 - 2.5)) and grid.is_free((8.5, 8.0 - 3.5))
    later = grid.with_zones(worker_keepouts([("w1", (8.5, 8.0), False)]))
    assert later.is_free((8.5, 8.0 - 2.5)) and not later.is_free((8.5, 8.0 - 0.9))
    assert later.with_zones([]).is_free((8.5, 8.0))


def test_keepout_polygons_and_bad_zones(site_grid):
    grid = site_grid.with_zones([KeepOut.polygon("pit", [(8.0, 7.0), (10.0, 7.0), (10.0, 9.0), (8.0, 9.0)])])
    assert not grid.is_free((9.0, 8.0))
    with pytest.raises(PlanningError, match="not a zone: str"):
        site_grid.with_zones(["pit"])
    with pytest.raises(PlanningError, match="radius must be > 0"):
        KeepOut.circle("w", (1.0, 1.0), 0.0)


@pytest.mark.parametrize("kwargs, message", [
    ({"resolution": 0}, r"resolution must be a number of metres > 0 \(got 0\)"),
    ({"resolution": float("nan")}, "resolution must be"),
    ({"robot_radius": -0.1}, "robot_radius must be"),
    ({"height_band": (1.2, 0.05)}, "height_band must be"),
    ({"resolution": 0.0005}, "use a coarser resolution"),
    ({"doors": "ajar"}, "door policy 'ajar'"),
])
def test_bad_grid_parameters_are_one_line_errors(site_model, kwargs, message):
    with pytest.raises(PlanningError, match=message) as error:
        OccupancyGrid.from_bim(site_model, **kwargs)
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("kwargs, message", [
    ({"origin_xy": (float("nan"), 0.0)}, r"origin_xy must be a finite \(x, y\)"),
    ({"origin_xy": (0.0, float("inf"))}, "origin_xy must be"), ({"origin_xy": (1.0,)}, "origin_xy must be"),
    ({"origin_xy": "here"}, "origin_xy must be"), ({"floor_z": float("nan")}, "floor_z must be"),
])
def test_bad_occupancy_grid_parameters_are_one_line_errors(kwargs, message):
    with pytest.raises(PlanningError, match=message) as error:
        OccupancyGrid.from_occupancy(np.zeros((10, 10), bool), 0.1, **kwargs)
    assert "\n" not in str(error.value)


def test_a_bim_with_no_walls_is_a_one_line_error(building):
    with pytest.raises(PlanningError, match="the BIM has no walls"):
        OccupancyGrid.from_bim(building(walls=False))


def test_a_model_read_without_geometry_says_so(site_model):
    from bim2rdt.bim import load_ifc

    with pytest.raises(PlanningError, match="loaded without geometry"):
        OccupancyGrid.from_bim(load_ifc(site_model.path, geometry=False))
