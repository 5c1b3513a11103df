"""`bim2rdt demo --ifc FILE`: the loop on real buildings. The FZK house (IFC4): site objects placed in its rooms,
the robot walks room to room through the doors, never through a wall, and the twin is written back. (Duplex,
IFC2X3, without IFC write-back, and a building with no floor: test_demo_every_ifc.py, on its runs.) The house's
day is the session's one run (``fzk_day``, tests/conftest.py), shared with test_demo_determinism.py."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.demo.ifc_day import run_ifc_day
from bim2rdt.planning.raster import mesh_cells

from path_checks import segments_through, wall_mesh

pytestmark = pytest.mark.samples


def test_site_objects_stand_on_the_ground_floor_slab_in_the_copy(fzk_day):
    day, out = fzk_day.day, fzk_day.out
    proxies = [el for el in day.model.elements if el.ifc_class == "IfcBuildingElementProxy"]
    assert len(proxies) >= 4 and all(el.storey == "Erdgeschoss" for el in proxies)
    assert all(abs(day.model.mesh(el.global_id)[0][:, 2].min() - 0.0) < 0.01 for el in proxies)
    assert day.model.path == out / "site.ifc" and day.twin_path == out / "site_twin.ifc" and day.twin_path.is_file()


def test_the_robot_walks_room_to_room_through_doors_and_never_through_a_wall(fzk_day):
    day = fzk_day.day
    legs = [leg.path for leg in day.route.navigator.legs]
    walls = wall_mesh(day.model)
    assert all(segments_through(walls, path) == [] for path in legs)
    grid = day.route.grid
    rooms = [z for z in day.model.zones if z.ifc_class == "IfcSpace" and z.storey == "Erdgeschoss"]
    visited = {room.name for room in rooms for T in day.mission.stations if _inside(grid, day.model, room, T[:2, 3])}
    assert len(visited) >= 4
    doors = [el for el in day.model.elements if el.ifc_class == "IfcDoor" and el.storey == "Erdgeschoss"]
    crossed = {door.name for door in doors for path in legs if _crosses(door, day.model, path)}
    assert len(crossed) >= 2


def test_every_placed_object_is_seen_and_judged(fzk_day):
    day = fzk_day.day
    assert day.mission.not_seen == [] and day.route.route.skipped == {}
    new = [obs for obs in day.mission.observations if obs.global_id is None]
    assert len(new) <= 1 and all(obs.family == "Steel_Drum_55gal" for obs in new)   # only the unplanned drum


def test_the_robot_sees_the_house_through_the_embedded_days_camera_and_detector_and_judges_right(fzk_day):
    """demo --ifc reads its frames as the embedded day does: the camera inside the building (walls in view),
    the geometric detector, no ideal masks. Scored afterwards against the simulator: what moved or was knocked
    is deviating, what did not is as planned."""
    from bim2rdt.demo.site_report import observation_rows

    day = fzk_day.day
    assert day.reality.scene.building
    rows = observation_rows(day)
    assert rows and all(r["truth"] is not None for r in rows)
    assert all(r["status"] == "deviating" for r in rows if r["truth"] in ("moved", "knocked"))
    assert all(r["status"] == "as planned" for r in rows if r["truth"] == "unchanged")


def test_the_ifc_day_takes_the_embedded_days_detectors(samples, tmp_path):
    with pytest.raises(ValueError, match="unknown detector 'oracle'; choose one of geometric, yoloe, ideal"):
        run_ifc_day(samples / "AC20-FZK-Haus.ifc", tmp_path / "out", workers=1, minutes=1.0, detector="oracle")
    assert not (tmp_path / "out").exists()  # refused before the day began


def _inside(grid, model, room, xy) -> bool:
    row0, col0, mask = mesh_cells(*model.mesh(room.global_id), grid.z_band, grid.frame)
    row, col = grid.frame.cell_of(xy)
    return 0 <= row - row0 < mask.shape[0] and 0 <= col - col0 < mask.shape[1] and bool(mask[row - row0, col - col0])


def _crosses(door, model, path) -> bool:
    """Does the path pass through the door's plan box (its leaf stands in the opening)?"""
    vertices = model.mesh(door.global_id)[0][:, :2]
    low, high = vertices.min(axis=0) - 0.05, vertices.max(axis=0) + 0.05
    for a, b in zip(path[:-1], path[1:]):
        points = a + np.linspace(0.0, 1.0, 200)[:, None] * (b - a)
        if np.any(np.all((points >= low) & (points <= high), axis=1)):
            return True
    return False
