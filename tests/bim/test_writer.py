"""TwinWriter round trips: what it writes, the reader reads back; the file stays valid IFC."""

from __future__ import annotations

import shutil
from datetime import datetime, timedelta, timezone

import ifcopenshell
import ifcopenshell.validate
import numpy as np
import pytest

from bim2rdt.bim import BimError, TwinWriter, load_ifc
from bim2rdt.sim.meshes import mesh_for_family
from bim2rdt.sim.site import yaw_pose

T0 = datetime(2026, 11, 26, 10, 5, 12, tzinfo=timezone.utc)


def _errors(path, express_rules: bool = False) -> list[str]:
    """Schema errors (and EXPRESS WHERE-rule errors, ~4 s per file, when asked) of an IFC file."""
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(ifcopenshell.open(str(path)), logger, express_rules=express_rules)
    return [str(s["message"]).split("\n")[0] for s in logger.statements]


@pytest.fixture
def writer(site_model):
    return TwinWriter(site_model)


def _cone(model):
    return next(el for el in model.elements if el.family == "Traffic_Cone_Orange_70cm")


def test_a_moved_element_is_read_back_at_its_new_pose_with_its_mesh_moved(writer, site_model, tmp_path):
    cone = _cone(site_model)
    pose = yaw_pose(3.3, 2.4, 0.0, 45.0)
    writer.move_element(cone.global_id, pose)
    again = load_ifc(writer.save(tmp_path / "moved.ifc"), cache_dir=tmp_path / "cache")
    assert np.allclose(again.element(cone.global_id).placement, pose, atol=1e-9)
    before, _ = site_model.mesh(cone.global_id)
    after, _ = again.mesh(cone.global_id)
    expected = (before - cone.position) @ pose[:3, :3].T + pose[:3, 3]
    assert np.allclose(np.sort(after, axis=0), np.sort(expected, axis=0), atol=1e-5)


def test_an_added_object_is_a_proxy_with_family_storey_mesh_and_typed_observation_pset(writer, tmp_path):
    drum = mesh_for_family("Steel_Drum_55gal")
    pose = yaw_pose(7.0, 3.0, 0.0, 10.0)
    gid = writer.add_object("Steel_Drum_55gal", drum.vertices, drum.faces, pose,
                            properties={"fitness": 0.93, "points": 412, "detector": "geometric", "upright": True})
    again = load_ifc(writer.save(tmp_path / "added.ifc"), cache_dir=tmp_path / "cache")
    element = again.element(gid)
    assert (element.ifc_class, element.family, element.storey) == ("IfcBuildingElementProxy", "Steel_Drum_55gal",
                                                                   "Ground Floor")
    assert np.allclose(element.placement, pose)
    assert element.psets["BIM2RDT_Observation"] == {"fitness": 0.93, "points": 412, "detector": "geometric",
                                                    "upright": True}
    vertices, _ = again.mesh(gid)
    world = drum.vertices @ pose[:3, :3].T + pose[:3, 3]
    assert np.allclose(vertices.min(axis=0), world.min(axis=0), atol=1e-4)
    assert np.allclose(vertices.max(axis=0), world.max(axis=0), atol=1e-4)


def test_events_and_tasks_round_trip_with_exact_times_links_and_sequence(writer, site_model, tmp_path):
    zone = next(z for z in site_model.zones if z.kind == "work")
    start = writer.add_event("HAV exposure start", T0, "start", related=[zone.global_id],
                             properties={"a_hv_m_s2": 7.5, "worker": "w-3f9a"})
    limit = writer.add_event("HAV action value reached", T0 + timedelta(minutes=10), "intermediate",
                             related=[zone.global_id], trigger="EVENTRULE")
    task = writer.add_task("Safety instructor intervention", (T0 + timedelta(minutes=10, seconds=7)).timestamp(),
                           T0 + timedelta(minutes=25, seconds=3), related=[zone.global_id], after=limit,
                           properties={"A8_m_s2": 2.5})
    again = load_ifc(writer.save(tmp_path / "hav.ifc"), cache_dir=tmp_path / "cache")
    events = {e.global_id: e for e in again.events}
    assert events[start].kind == "STARTEVENT" and events[start].start == T0
    assert events[start].trigger == "EVENTMESSAGE" and events[limit].trigger == "EVENTRULE"
    assert events[start].related == (zone.global_id,)
    assert events[start].psets["BIM2RDT_Event"] == {"a_hv_m_s2": 7.5, "worker": "w-3f9a"}
    (read_task,) = [t for t in again.tasks if t.global_id == task]
    # not snapped to 09:00/17:00 as sequence.edit_task_time would do
    assert read_task.start == T0 + timedelta(minutes=10, seconds=7)
    assert read_task.finish == T0 + timedelta(minutes=25, seconds=3)
    assert read_task.related == (zone.global_id,) and read_task.after == (limit,)


def test_the_written_file_adds_no_validation_errors(writer, site_model, site_ifc, tmp_path):
    cone = _cone(site_model)
    writer.move_element(cone.global_id, yaw_pose(3.0, 2.5, 0.0, 90.0))
    crate = mesh_for_family("Wooden_Crate_1200x800x600")
    writer.add_object("Wooden_Crate_1200x800x600", crate.vertices, crate.faces, yaw_pose(5, 9, 0, 0))
    event = writer.add_event("start", T0, "start", related=[cone.global_id])
    task = writer.add_task("intervene", T0, related=[cone.global_id], after=event)
    writer.add_sequence(task, writer.add_event("end", T0 + timedelta(hours=1), "end"))
    out = writer.save(tmp_path / "twin.ifc")
    assert _errors(site_ifc) == []  # the source passes EXPRESS rules too: tests/sim/test_site.py
    assert _errors(out, express_rules=True) == []


def test_a_geometry_located_element_in_a_millimetre_file_moves_exactly(samples, tmp_path):
    """Revit puts some elements at the identity with geometry elsewhere: the writer re-bases their body."""
    model = load_ifc(samples / "TestModel_IFC4Add2.ifc", cache_dir=tmp_path / "cache")
    part = next(el for el in model.elements if el.placement_from_geometry and el.ifc_class != "IfcSpace")
    wall = next(el for el in model.elements if el.ifc_class == "IfcWall")
    writer = TwinWriter(model)
    shifted = part.placement.copy()
    shifted[:3, 3] += (1.0, 2.0, 0.0)
    turned = wall.placement @ yaw_pose(0.5, 0.0, 0.0, 10.0)
    writer.move_element(part.global_id, shifted)
    writer.move_element(wall.global_id, turned)
    out = writer.save(tmp_path / "moved.ifc")
    again = load_ifc(out, cache_dir=tmp_path / "cache")
    assert np.allclose(again.element(part.global_id).placement, shifted, atol=1e-6)
    assert np.allclose(again.element(wall.global_id).placement, turned, atol=1e-6)
    moved_low = again.mesh(part.global_id)[0].min(axis=0)
    assert np.allclose(moved_low, model.mesh(part.global_id)[0].min(axis=0) + (1.0, 2.0, 0.0), atol=1e-5)
    assert _errors(out) == []


def test_ifc2x3_is_refused_with_a_message_naming_the_schema(sample_model):
    with pytest.raises(BimError, match="IFC2X3.*IfcEvent"):
        TwinWriter(sample_model("Duplex_A_20110907.ifc"))


def test_bad_writer_input_gives_bim_errors(writer, site_model):
    with pytest.raises(BimError, match="no element"):
        writer.move_element("0000000000000000000000", np.eye(4))
    with pytest.raises(BimError, match="4x4"):
        writer.move_element(_cone(site_model).global_id, np.eye(3))
    with pytest.raises(BimError, match="rotation"):
        writer.move_element(_cone(site_model).global_id, np.diag([2.0, 1.0, 1.0, 1.0]))
    with pytest.raises(BimError, match="kind"):
        writer.add_event("x", T0, kind="middle")
    with pytest.raises(BimError, match="no IFC type"):
        writer.add_event("x", T0, properties={"bad": object()})
    with pytest.raises(BimError, match="no storey"):
        writer.add_object("Pallet_Wood_EUR", np.eye(3), [[0, 1, 2]], np.eye(4), storey="Level 99")


def test_a_writer_refuses_a_file_that_changed_after_loading(site_ifc, tmp_path):
    copy = tmp_path / "site.ifc"
    shutil.copy(site_ifc, copy)
    model = load_ifc(copy, cache_dir=tmp_path / "cache")
    copy.write_text(copy.read_text().replace("Block A", "Block B"))
    with pytest.raises(BimError, match="changed on disk"):
        TwinWriter(model)


def test_an_ifc4x3_site_round_trips_moves_events_and_tasks(tmp_path):
    from bim2rdt.sim.site import build_site_ifc

    model = load_ifc(build_site_ifc(tmp_path / "site4x3.ifc", schema="IFC4X3"), cache_dir=tmp_path / "cache")
    assert model.schema == "IFC4X3"
    writer = TwinWriter(model)
    cone = _cone(model)
    writer.move_element(cone.global_id, yaw_pose(3.0, 3.0, 0.0, 30.0))
    event = writer.add_event("start", T0, "start", related=[cone.global_id])
    task = writer.add_task("intervene", T0, T0 + timedelta(minutes=5), related=[cone.global_id], after=event)
    out = writer.save(tmp_path / "twin4x3.ifc")
    again = load_ifc(out, cache_dir=tmp_path / "cache")
    assert np.allclose(again.element(cone.global_id).placement, yaw_pose(3.0, 3.0, 0.0, 30.0))
    assert [e.global_id for e in again.events] == [event]
    planned = {t.global_id for t in model.tasks}  # the site's work schedule (sim.schedule)
    assert [(t.global_id, t.after) for t in again.tasks if t.global_id not in planned] == [(task, (event,))]
    assert _errors(out) == []


def test_a_model_read_without_geometry_is_tessellated_only_when_an_element_moves(samples, tmp_path):
    """Events and tasks need no geometry; moves of Revit's identity-placed elements do."""
    with_geometry = load_ifc(samples / "TestModel_IFC4Add2.ifc", cache_dir=tmp_path / "cache")
    part = next(el for el in with_geometry.elements if el.placement_from_geometry and el.ifc_class != "IfcSpace")
    writer = TwinWriter(load_ifc(samples / "TestModel_IFC4Add2.ifc", geometry=False))
    writer.add_event("start", T0, "start", related=[part.global_id])
    assert writer.model.meshes is None
    shifted = part.placement.copy()
    shifted[:3, 3] += (1.0, 2.0, 0.0)
    writer.move_element(part.global_id, shifted)
    again = load_ifc(writer.save(tmp_path / "moved.ifc"), cache_dir=tmp_path / "cache")
    assert np.allclose(again.element(part.global_id).placement, shifted, atol=1e-6)
    assert np.allclose(again.mesh(part.global_id)[0].min(axis=0),
                       with_geometry.mesh(part.global_id)[0].min(axis=0) + (1.0, 2.0, 0.0), atol=1e-5)


def test_an_added_object_can_keep_the_global_id_it_already_has(writer, tmp_path):
    drum = mesh_for_family("Steel_Drum_55gal")
    gid = writer.add_object("Steel_Drum_55gal", drum.vertices, drum.faces, yaw_pose(7.0, 3.0, 0.0, 0.0),
                            global_id="2Xq$SNz5P0suRzqFdBk9Yp")
    assert gid == "2Xq$SNz5P0suRzqFdBk9Yp"
    again = load_ifc(writer.save(tmp_path / "kept.ifc"), cache_dir=tmp_path / "cache")
    assert again.element(gid).family == "Steel_Drum_55gal"
    with pytest.raises(BimError, match="already taken"):
        writer.add_object("Steel_Drum_55gal", drum.vertices, drum.faces, np.eye(4), global_id=gid)
    with pytest.raises(BimError, match="not an IFC GlobalId"):
        writer.add_object("Steel_Drum_55gal", drum.vertices, drum.faces, np.eye(4), global_id="drum-1")


def test_properties_added_to_an_existing_element_are_read_back_typed(writer, site_model, tmp_path):
    cone = _cone(site_model)
    writer.add_properties(cone.global_id, {"Status": "deviating", "TranslationMetres": 0.3, "Station": 2})
    again = load_ifc(writer.save(tmp_path / "props.ifc"), cache_dir=tmp_path / "cache")
    assert again.element(cone.global_id).psets["BIM2RDT_Observation"] == {"Status": "deviating",
                                                                          "TranslationMetres": 0.3, "Station": 2}
