"""Reading the shared real IFC files: schema, units, storeys, counts, families, placements vs meshes, caching."""

from __future__ import annotations

import ifcopenshell
import ifcopenshell.api.geometry
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.util.representation
import numpy as np
import pytest

from bim2rdt.bim import BimError, load_ifc

# expected facts, from the sample files' SOURCES.md (written independently of this reader)
SAMPLES = {
    "AC20-FZK-Haus.ifc": dict(schema="IFC4", scale=1.0, storeys=2,
                              counts={"IfcWall": 13, "IfcSlab": 4, "IfcDoor": 5, "IfcWindow": 11, "IfcBeam": 4,
                                      "IfcMember": 42},
                              family="Leichtbeton 102890359 300"),
    "Duplex_A_20110907.ifc": dict(schema="IFC2X3", scale=1.0, storeys=4,
                                  counts={"IfcWall": 57, "IfcSlab": 21, "IfcDoor": 14, "IfcWindow": 24,
                                          "IfcBeam": 8, "IfcFooting": 7},
                                  family="Basic Wall:Exterior - Brick on Block"),
    "Office_A_20110811.ifc": dict(schema="IFC2X3", scale=1.0, storeys=3,
                                  counts={"IfcWall": 487, "IfcDoor": 102, "IfcWindow": 69, "IfcCovering": 83,
                                          "IfcSpace": 99},
                                  family="Basic Wall:Interior - Partition (92mm Stud)"),
    "TestModel_IFC4Add2.ifc": dict(schema="IFC4", scale=0.001, storeys=2,
                                   counts={"IfcWall": 4, "IfcSlab": 2, "IfcDoor": 2, "IfcWindow": 7},
                                   family="Basic Wall:常规 - 200mm"),
    "construction_scheduling_task.ifc": dict(schema="IFC4", scale=0.0254, storeys=1,
                                             counts={"IfcWall": 4, "IfcSlab": 1}, family="Wall #1"),
}


def _count(model, prefix: str) -> int:
    """IfcWall counts IfcWall + IfcWallStandardCase, etc."""
    return sum(1 for el in model.elements if el.ifc_class.startswith(prefix))


@pytest.mark.parametrize("name", sorted(SAMPLES))
def test_each_sample_reads_with_its_schema_unit_storeys_counts_and_a_known_family(sample_model, name):
    expected, model = SAMPLES[name], sample_model(name)
    assert model.schema == expected["schema"]
    assert model.unit_scale == pytest.approx(expected["scale"])
    assert len(model.storeys) == expected["storeys"]
    assert {cls: _count(model, cls) for cls in expected["counts"]} == expected["counts"]
    assert expected["family"] in model.families()
    assert not model.geometry_failures


@pytest.mark.parametrize("name", sorted(SAMPLES))
def test_a_wall_placement_in_metres_lies_on_its_tessellated_body(sample_model, name):
    """Placements are scaled to metres (mm and inch files) and agree with the iterator's world meshes."""
    model = sample_model(name)
    wall = next(el for el in model.elements if el.ifc_class.startswith("IfcWall"))
    vertices, faces = model.mesh(wall.global_id)
    assert len(faces) > 0 and faces.max() < len(vertices)
    assert np.all(wall.position >= vertices.min(axis=0) - 0.05)
    assert np.all(wall.position <= vertices.max(axis=0) + 0.05)
    assert wall.placement.shape == (4, 4) and wall.placement.dtype == np.float64


def test_storey_elevations_are_in_metres_in_a_millimetre_file(sample_model):
    model = sample_model("TestModel_IFC4Add2.ifc")
    assert [s.elevation for s in model.storeys] == pytest.approx([0.0, 4.0])


def test_revit_elements_with_an_identity_placement_take_their_location_from_geometry(sample_model):
    model = sample_model("TestModel_IFC4Add2.ifc")
    located = [el for el in model.elements if el.placement_from_geometry]
    assert located, "TestModel has Revit stair parts placed at the identity"
    for el in located:
        vertices, _ = model.mesh(el.global_id)
        centre = (vertices.min(axis=0) + vertices.max(axis=0)) / 2
        assert el.position[:2] == pytest.approx(centre[:2])
        assert el.position[2] == pytest.approx(vertices[:, 2].min())


def test_elements_know_their_storey_and_psets_exclude_quantity_sets(sample_model):
    model = sample_model("AC20-FZK-Haus.ifc")
    storeys = {s.name for s in model.storeys}
    walls = [el for el in model.elements if el.ifc_class.startswith("IfcWall")]
    assert all(el.storey in storeys for el in walls)
    assert any("Pset_WallCommon" in el.psets for el in walls)
    assert not any(name.startswith("Qto_") or name.startswith("BaseQuantities")
                   for el in model.elements for name in el.psets)


def test_a_second_load_of_the_same_bytes_comes_from_the_cache_with_the_same_content(samples, tmp_path):
    first = load_ifc(samples / "TestModel_IFC4Add2.ifc", cache_dir=tmp_path)
    second = load_ifc(samples / "TestModel_IFC4Add2.ifc", cache_dir=tmp_path)
    assert not first.from_cache and second.from_cache
    assert [el.global_id for el in first.elements] == [el.global_id for el in second.elements]
    for a, b in zip(first.elements, second.elements):
        assert a.family == b.family and a.storey == b.storey and a.psets == b.psets
        assert np.allclose(a.placement, b.placement)
    gid = first.elements[0].global_id
    assert np.array_equal(first.mesh(gid)[0], second.mesh(gid)[0])
    assert (second.site_frame.source, second.site_frame.latitude_deg) == (first.site_frame.source,
                                                                         first.site_frame.latitude_deg)


def test_the_cache_is_keyed_by_content_so_an_edited_file_is_read_again(samples, tmp_path):
    path = tmp_path / "model.ifc"
    text = (samples / "construction_scheduling_task.ifc").read_text(encoding="latin-1")
    path.write_text(text, encoding="latin-1")
    assert load_ifc(path, cache_dir=tmp_path / "cache").families().get("Wall #1") == 1
    path.write_text(text.replace("'Wall #1'", "'Wall #9'"), encoding="latin-1")
    edited = load_ifc(path, cache_dir=tmp_path / "cache")
    assert not edited.from_cache and "Wall #9" in edited.families()


@pytest.mark.parametrize("damage", [b"", b"PK\x03\x04 not a zip", "half"])
def test_a_damaged_cache_is_ignored_and_rewritten(site_ifc, tmp_path, damage):
    first = load_ifc(site_ifc, cache_dir=tmp_path)
    (cache,) = tmp_path.glob("*.npz")
    cache.write_bytes(cache.read_bytes()[: cache.stat().st_size // 2] if damage == "half" else damage)
    again = load_ifc(site_ifc, cache_dir=tmp_path)
    assert not again.from_cache and [el.global_id for el in again.elements] == [el.global_id for el in first.elements]
    assert load_ifc(site_ifc, cache_dir=tmp_path).from_cache  # the damaged file was replaced by a whole one


def test_the_configured_cache_lives_under_the_cache_dir_and_no_cache_dir_means_no_cache(samples, tmp_path,
                                                                                           monkeypatch):
    from bim2rdt.config import get_settings, ifc_cache_dir

    monkeypatch.setenv("BIM2RDT_CACHE_DIR", str(tmp_path))
    get_settings.cache_clear()
    load_ifc(samples / "construction_scheduling_task.ifc")
    assert not list(tmp_path.glob("**/*.npz"))  # library code reads no settings
    load_ifc(samples / "construction_scheduling_task.ifc", cache_dir=ifc_cache_dir(get_settings()))
    assert list((tmp_path / "ifc").glob("*.npz"))
    monkeypatch.setenv("BIM2RDT_BIM__TESSELLATION_CACHE", "false")
    get_settings.cache_clear()
    assert ifc_cache_dir(get_settings()) is None


def test_an_element_whose_geometry_fails_is_reported_and_the_rest_still_tessellates(site_ifc, tmp_path):
    ifc = ifcopenshell.open(str(site_ifc))
    broken = _add_broken_proxy(ifc)
    ifc.write(str(tmp_path / "broken.ifc"))
    model = load_ifc(tmp_path / "broken.ifc", cache_dir=tmp_path / "cache")
    assert [f.global_id for f in model.geometry_failures] == [broken]
    assert model.geometry_failures[0].reason
    assert sum(model.has_mesh(el.global_id) for el in model.elements) == len(model.elements) - 1
    assert model.mesh(broken)[0].shape == (0, 3) and model.mesh(broken)[1].shape == (0, 3)


def test_asking_for_the_mesh_of_an_unknown_element_names_it(site_model):
    with pytest.raises(BimError, match="no element with GlobalId nope"):
        site_model.mesh("nope")


def _add_broken_proxy(ifc: ifcopenshell.file) -> str:
    """A proxy whose triangulated body indexes a vertex that does not exist (the kernel rejects it)."""
    context = ifcopenshell.util.representation.get_context(ifc, "Model", "Body", "MODEL_VIEW")
    points = ifc.create_entity("IfcCartesianPointList3D", CoordList=[(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)])
    body = ifc.create_entity("IfcTriangulatedFaceSet", Coordinates=points, CoordIndex=[(1, 2, 9)])
    representation = ifc.create_entity("IfcShapeRepresentation", ContextOfItems=context, RepresentationIdentifier="Body",
                                       RepresentationType="Tessellation", Items=[body])
    proxy = ifcopenshell.api.root.create_entity(ifc, "IfcBuildingElementProxy", name="broken")
    ifcopenshell.api.geometry.assign_representation(ifc, product=proxy, representation=representation)
    ifcopenshell.api.spatial.assign_container(ifc, products=[proxy], relating_structure=ifc.by_type("IfcBuildingStorey")[0])
    ifcopenshell.api.geometry.edit_object_placement(ifc, product=proxy)
    return proxy.GlobalId


def test_the_4d_sample_tasks_come_with_planned_times_links_and_sequence(sample_model):
    from datetime import datetime, timezone

    tasks = {task.name: task for task in sample_model("construction_scheduling_task.ifc").tasks}
    assert len(tasks) == 8
    wall = tasks["Wall #2"]
    assert wall.start == datetime(2010, 9, 22, 8, tzinfo=timezone.utc)
    assert wall.finish == datetime(2010, 9, 22, 16, tzinfo=timezone.utc)
    assert tasks["Wall #1"].global_id in wall.after
    assert len(wall.related) == 1
