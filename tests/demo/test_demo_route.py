"""The demo day's robot walks planned paths: never through a wall (checked against the BIM's wall meshes, not the
planner's grid), never into the off-limits zone, around the unplanned drum and around a worker while their tool
runs, and every station sees its object."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.planning import OccupancyGrid, line_of_sight
from bim2rdt.planning.zones import WORKER_LIVE_RADIUS

from path_checks import segments_through, wall_mesh

ROBOT_RADIUS = 0.35


@pytest.fixture(scope="module")
def day(demo_run):
    """The site day of the session's demo run (tests/conftest.py: one worker, 40 minutes of tool work)."""
    return demo_run.day


def legs(day):
    return day.route.navigator.legs


def test_no_leg_of_the_walk_crosses_a_wall_or_a_column(day):
    walls = wall_mesh(day.model)
    assert len(legs(day)) >= len(day.mission.stations)
    for leg in legs(day):
        assert segments_through(walls, leg.path) == [], leg


def test_the_robot_stays_out_of_the_off_limits_zone(day):
    (x0, y0, x1, y1) = (14.0, 1.0, 19.0, 5.0)
    for leg in legs(day):
        for a, b in zip(leg.path[:-1], leg.path[1:]):
            for p in a + np.linspace(0, 1, 50)[:, None] * (b - a):
                gap = np.hypot(max(x0 - p[0], 0, p[0] - x1), max(y0 - p[1], 0, p[1] - y1))
                assert gap >= ROBOT_RADIUS - 0.03, p


def test_the_robot_saw_the_unplanned_drum_ahead_and_walked_round_it(day):
    drum = next(t.T_world_model[:2, 3] for t in day.reality.truth if t.change == "unplanned")
    assert any("Steel_Drum_55gal (observed object)" in r.reason for r in day.route.navigator.replans)
    closest = min(np.min(np.linalg.norm(_samples(leg.path) - drum, axis=1)) for leg in legs(day))
    assert closest >= 0.29 + ROBOT_RADIUS - 0.05


def test_the_robot_keeps_out_of_a_workers_zone_while_their_tool_runs(day):
    workers = day.route.workers
    assert any("(worker)" in r.reason for r in day.route.navigator.replans)
    checked = 0
    for leg in legs(day):
        if leg.replanned and leg.replanned.startswith("stepped out"):
            continue  # the zone switched on around it: this is the way out
        times = np.linspace(leg.start_time, leg.end_time, 200)
        points = _along(leg.path, np.linspace(0.0, 1.0, 200))
        for t, p in zip(times[1:-1], points[1:-1]):
            for device, spot in workers.spots.items():
                if workers.live(device, t):
                    checked += 1
                    assert np.linalg.norm(p - spot) >= WORKER_LIVE_RADIUS + ROBOT_RADIUS - 0.1, (device, t, p)
    assert checked > 0


def test_every_station_was_reached_and_sees_its_object_over_the_walls(day):
    grid = OccupancyGrid.from_bim(day.model)
    assert day.route.route.skipped == {} and day.route.plan.unplaced == {}
    for station, target in zip(day.mission.stations, day.route.plan.targets):
        assert line_of_sight(grid, station[:2, 3], target.placement[:2, 3], ignore=[target.global_id])
    assert day.mission.not_seen == []


def _samples(path, step=0.02):
    return np.vstack([a + np.linspace(0, 1, max(int(np.linalg.norm(b - a) / step), 1) + 1)[:, None] * (b - a)
                      for a, b in zip(path[:-1], path[1:])])


def _along(path, fractions):
    lengths = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))]
    at = fractions * lengths[-1]
    return np.stack([np.interp(at, lengths, path[:, 0]), np.interp(at, lengths, path[:, 1])], axis=1)


def test_the_report_gets_the_plan_map_and_a_nav2_map_with_what_the_twin_found(day, demo_run):
    """The demo's report wrote them (``write_route_files``, with the day's twin open) into its folder."""
    from nav2_maps import read_pgm

    out, written = demo_run.out, demo_run.result.report
    assert written["plan_map"] == out / "plan_map.png" and written["plan_map"].stat().st_size > 10_000
    assert written["nav2_image"] == out / "nav2" / "site.pgm"
    occupied = read_pgm(out / "nav2" / "site.pgm")[::-1] == 0
    grid = day.route.grid
    drum = next(t.T_world_model[:2, 3] for t in day.reality.truth if t.change == "unplanned")
    assert occupied[grid.frame.cell_of(drum)]                 # the twin's new drum is on the map
    assert not (day.route.grid.occupied[grid.frame.cell_of(drum)])   # the BIM alone did not have it
    keepout = read_pgm(out / "nav2" / "site_keepout.pgm")[::-1] == 0
    assert keepout[grid.frame.cell_of((16.5, 3.0))] and not keepout[grid.frame.cell_of((9.0, 8.0))]
