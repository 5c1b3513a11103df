"""pick_viewpoint: the first proposed viewpoint that is free, reachable and sees its target over the walls."""

from __future__ import annotations

from bim2rdt.planning import OccupancyGrid, pick_viewpoint, reachable

DOCK = (1.0, 1.0)


def test_a_viewpoint_behind_a_wall_inside_a_column_or_in_a_closed_room_is_passed_over(site_grid, site_model):
    target = (13.5, 10.5)                                       # in the east room
    region = reachable(site_grid, DOCK)
    candidates = [(10.5, 10.5),   # west of the interior wall: reachable, but the wall hides the target
                  (14.0, 10.0),   # column C23
                  (15.5, 12.0)]   # in the east room, sees it
    assert pick_viewpoint(site_grid, target, candidates, region) == 2
    closed = OccupancyGrid.from_bim(site_model, doors="closed")
    assert pick_viewpoint(closed, target, candidates, reachable(closed, DOCK)) is None


def test_the_reachable_region_excludes_keepout_zones_and_is_empty_from_a_blocked_start(site_grid, site_model):
    zoned = site_grid.with_zones(site_model.zones)
    region = reachable(zoned, DOCK)
    assert region[zoned.frame.cell_of((9.0, 8.0))] and not region[zoned.frame.cell_of((16.5, 3.0))]
    assert not reachable(site_grid, (6.0, 5.0)).any()
