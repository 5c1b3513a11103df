"""sim.furnish: site objects placed in free, reachable floor of a real building, one per room, written into a
copy that reads back with the objects on the storey, byte for byte the same each time."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.bim import load_ifc
from bim2rdt.planning import OccupancyGrid, reachable
from bim2rdt.sim.furnish import CLEARANCE, furnish, write_furnished

pytestmark = pytest.mark.samples


@pytest.fixture(scope="module")
def fzk(samples, tmp_path_factory):
    model = load_ifc(samples / "AC20-FZK-Haus.ifc", cache_dir=tmp_path_factory.mktemp("furnish-cache"))
    grid = OccupancyGrid.from_bim(model).with_zones(model.zones)
    return model, grid, furnish(model, grid, workers=1, seed=0)


def test_objects_stand_in_free_reachable_floor_with_room_around_them(fzk):
    model, grid, layout = fzk
    assert len(layout.objects) >= 4 and layout.storey == "Erdgeschoss" and layout.floor_z == pytest.approx(0.0)
    region = reachable(grid, layout.dock_xy)
    from scipy import ndimage
    clearance = ndimage.distance_transform_edt(~grid.occupied) * grid.resolution
    for item in layout.objects:
        cell = grid.frame.cell_of((item.x, item.y))
        assert region[cell] and clearance[cell] >= CLEARANCE
    spots = np.array([(o.x, o.y) for o in layout.objects] + [layout.dock_xy])
    gaps = np.linalg.norm(spots[:, None] - spots[None], axis=2) + np.eye(len(spots)) * 99
    assert gaps.min() >= 2.5


def test_one_object_per_room(fzk):
    model, grid, layout = fzk
    rooms = {}
    from bim2rdt.planning.raster import mesh_cells
    for zone in model.zones:
        if zone.ifc_class == "IfcSpace" and zone.storey == "Erdgeschoss":
            row0, col0, mask = mesh_cells(*model.mesh(zone.global_id), grid.z_band, grid.frame)
            for item in layout.objects:
                r, c = grid.frame.cell_of((item.x, item.y))
                if 0 <= r - row0 < mask.shape[0] and 0 <= c - col0 < mask.shape[1] and mask[r - row0, c - col0]:
                    rooms.setdefault(zone.name, []).append(item.family)
    assert len(rooms) == len(layout.objects) and all(len(v) == 1 for v in rooms.values())


def test_the_copy_holds_the_objects_on_the_storey_and_is_the_same_bytes_each_time(fzk, tmp_path):
    model, _, layout = fzk
    first = write_furnished(model, layout, tmp_path / "a.ifc")
    second = write_furnished(model, layout, tmp_path / "b.ifc")
    assert first.read_bytes() == second.read_bytes()
    copy = load_ifc(first, cache_dir=tmp_path / "cache")
    proxies = [el for el in copy.elements if el.ifc_class == "IfcBuildingElementProxy"]
    assert sorted(el.family for el in proxies) == sorted(o.family for o in layout.objects)
    for el in proxies:
        item = next(o for o in layout.objects if np.allclose(el.position[:2], (o.x, o.y), atol=1e-6))
        assert el.storey == "Erdgeschoss" and el.family == item.family and copy.has_mesh(el.global_id)
        assert el.psets["BIM2RDT_SiteObject"]["Movable"] is True


def test_objects_placed_in_a_millimetre_model_keep_their_size_in_metres(samples, tmp_path):
    """TestModel_IFC4Add2 is in millimetres: a 55-gallon drum stays 0.6 m wide and 0.9 m tall (not 609 m)."""
    from bim2rdt.sim.meshes import mesh_for_family

    model = load_ifc(samples / "TestModel_IFC4Add2.ifc", cache_dir=tmp_path / "cache")
    assert model.unit_scale == pytest.approx(0.001)
    layout = furnish(model, OccupancyGrid.from_bim(model).with_zones(model.zones), workers=1, seed=0)
    copy = load_ifc(write_furnished(model, layout, tmp_path / "site.ifc"), cache_dir=tmp_path / "cache")
    proxies = [el for el in copy.elements if el.ifc_class == "IfcBuildingElementProxy"]
    assert proxies
    for el in proxies:
        size = np.ptp(copy.mesh(el.global_id)[0], axis=0)
        designed = mesh_for_family(el.family).extents
        assert np.sort(size[:2]) == pytest.approx(np.sort(designed[:2]), abs=0.01) and size[2] == \
            pytest.approx(designed[2], abs=0.01)
