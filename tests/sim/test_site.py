"""The embedded demo site: the elements the demo and the tests rely on, deterministic bytes, valid IFC."""

from __future__ import annotations

import ifcopenshell
import ifcopenshell.validate
import numpy as np

from bim2rdt.bim import load_ifc
from bim2rdt.sim.meshes import MESH_LIBRARY
from bim2rdt.sim.site import SITE_OBJECTS, build_site_ifc


def test_the_site_is_an_ifc4_shell_with_slab_walls_columns_door_and_one_storey(tmp_path):
    model = load_ifc(build_site_ifc(tmp_path / "site.ifc"), cache_dir=tmp_path / "cache")
    counts = model.counts_by_class()
    assert model.schema == "IFC4" and model.unit_scale == 1.0
    assert [s.name for s in model.storeys] == ["Ground Floor"]
    assert (counts["IfcSlab"], counts["IfcWall"], counts["IfcColumn"], counts["IfcDoor"]) == (1, 7, 6, 1)  # 7: the partition
    assert counts["IfcBuildingElementProxy"] == len(SITE_OBJECTS)
    assert not model.geometry_failures


def test_site_objects_carry_mesh_library_families_at_their_layout_poses(tmp_path):
    model = load_ifc(build_site_ifc(tmp_path / "site.ifc"), cache_dir=tmp_path / "cache")
    proxies = [el for el in model.elements if el.ifc_class == "IfcBuildingElementProxy"]
    assert {el.family for el in proxies} == {item.family for item in SITE_OBJECTS} <= set(MESH_LIBRARY)
    for el, item in zip(proxies, SITE_OBJECTS):
        assert el.family == item.family
        assert np.allclose(el.position, (item.x, item.y, 0.0))
        vertices, _ = model.mesh(el.global_id)
        assert vertices[:, 2].min() == np.float64(0.0) or abs(vertices[:, 2].min()) < 1e-6


def test_the_door_cuts_an_opening_through_its_wall(tmp_path):
    model = load_ifc(build_site_ifc(tmp_path / "site.ifc"), cache_dir=tmp_path / "cache")
    wall = next(el for el in model.elements if el.name == "Interior Wall - North/South")
    vertices, _ = model.mesh(wall.global_id)
    head = vertices[np.isclose(vertices[:, 2], 2.1)]  # the opening's head: only exists if the cut was made
    assert np.any(np.isclose(head[:, 1], 8.0)) and np.any(np.isclose(head[:, 1], 9.0))


def test_zones_are_tagged_and_the_site_is_geo_referenced(tmp_path):
    model = load_ifc(build_site_ifc(tmp_path / "site.ifc"), cache_dir=tmp_path / "cache")
    assert {(z.kind, z.off_limits) for z in model.zones} == {("work", False), ("exclusion", True)}
    assert model.site_frame.source == "IfcMapConversion" and model.site_frame.crs_name == "EPSG:25832"
    # rtol=0: allclose's default rtol=1e-5 would accept 54 m of error on a 5.43e6 m northing
    assert np.allclose(model.site_frame.to_map(np.zeros((1, 3))), [[456000.0, 5430000.0, 115.0]], rtol=0, atol=1e-6)


def test_two_builds_write_the_same_bytes_and_a_valid_file(tmp_path):
    first, second = build_site_ifc(tmp_path / "a.ifc"), build_site_ifc(tmp_path / "b.ifc")
    assert first.read_bytes() == second.read_bytes()
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(ifcopenshell.open(str(first)), logger, express_rules=True)
    assert logger.statements == []
