"""The twin exported: IFC (through TwinWriter, re-read with load_ifc), BCF (re-read with bcf-client) and JSON;
an IFC2X3 twin lives in the history, JSON and BCF, and says that IFC write-back needs IFC4."""

from __future__ import annotations

import json

import cv2
import ifcopenshell
import ifcopenshell.validate
import numpy as np
import pytest
from bcf.v2.bcfxml import BcfXml

from bim2rdt.bim import load_ifc
from bim2rdt.bus import Event
from bim2rdt.perception.camera import look_at
from bim2rdt.perception.observation import Observation
from bim2rdt.sim.site import ZONES, yaw_pose
from bim2rdt.twin import DigitalTwin, ElementStatus, TwinError

from twin_helpers import SYMMETRY, T0, family_mesh

IFC2X3_TEXT = """ISO-10303-21;
HEADER;
FILE_DESCRIPTION(('ViewDefinition [CoordinationView]'),'2;1');
FILE_NAME('tiny2x3.ifc','2026-01-01T00:00:00',(''),(''),'hand','hand','');
FILE_SCHEMA(('IFC2X3'));
ENDSEC;
DATA;
#1=IFCPERSON($,'Doe','Jo',$,$,$,$,$);
#2=IFCORGANIZATION($,'bim2rdt',$,$,$);
#3=IFCPERSONANDORGANIZATION(#1,#2,$);
#4=IFCAPPLICATION(#2,'0','tests','tests');
#5=IFCOWNERHISTORY(#3,#4,$,.ADDED.,$,$,$,1700000000);
#6=IFCSIUNIT(*,.LENGTHUNIT.,$,.METRE.);
#7=IFCUNITASSIGNMENT((#6));
#8=IFCCARTESIANPOINT((0.,0.,0.));
#9=IFCAXIS2PLACEMENT3D(#8,$,$);
#10=IFCGEOMETRICREPRESENTATIONCONTEXT($,'Model',3,1.E-05,#9,$);
#11=IFCPROJECT('0YvctVUKr0kugbFTf53O9L',#5,'Tiny',$,$,$,$,(#10),#7);
#12=IFCLOCALPLACEMENT($,#9);
#13=IFCSITE('1YvctVUKr0kugbFTf53O9L',#5,'Site',$,$,#12,$,$,.ELEMENT.,$,$,$,$,$);
#14=IFCLOCALPLACEMENT(#12,#9);
#15=IFCBUILDING('2YvctVUKr0kugbFTf53O9L',#5,'Building',$,$,#14,$,$,.ELEMENT.,$,$,$);
#16=IFCLOCALPLACEMENT(#14,#9);
#17=IFCBUILDINGSTOREY('3YvctVUKr0kugbFTf53O9L',#5,'Ground',$,$,#16,$,$,.ELEMENT.,0.);
#18=IFCRELAGGREGATES('0ZvctVUKr0kugbFTf53O9L',#5,$,$,#11,(#13));
#19=IFCRELAGGREGATES('1ZvctVUKr0kugbFTf53O9L',#5,$,$,#13,(#15));
#20=IFCRELAGGREGATES('2ZvctVUKr0kugbFTf53O9L',#5,$,$,#15,(#17));
#21=IFCCARTESIANPOINT((4.,3.,0.));
#22=IFCAXIS2PLACEMENT3D(#21,$,$);
#23=IFCLOCALPLACEMENT(#16,#22);
#24=IFCBUILDINGELEMENTPROXY('4YvctVUKr0kugbFTf53O9L',#5,'Pallet_Wood_EUR',$,'Pallet_Wood_EUR',#23,$,$,$);
#25=IFCRELCONTAINEDINSPATIALSTRUCTURE('3ZvctVUKr0kugbFTf53O9L',#5,$,$,(#24),#17);
ENDSEC;
END-ISO-10303-21;
"""


def _element(model, family):
    return next(el for el in model.elements if el.family == family)


@pytest.fixture
def day(tmp_path, site_model):
    """A twin of the site after a short day: a cone pushed 30 cm (deviating), the pallet as planned, an unplanned
    drum (new), the tripod gone (missing), and a worker's grinding with an EAV crossing in work zone A."""
    twin = DigitalTwin.open(f"sqlite:///{tmp_path / 'twin.db'}", site_model, symmetry=SYMMETRY, robot="spot-1",
                            family_mesh=family_mesh)
    cone, pallet = _element(site_model, "Traffic_Cone_Orange_70cm"), _element(site_model, "Pallet_Wood_EUR")
    tripod = _element(site_model, "Survey_Tripod_Aluminium")
    moved = cone.placement.copy()
    moved[:2, 3] += (0.3, 0.0)
    cameras = {name: look_at((x, y, 1.1), target) for name, (x, y, target) in {
        "cone": (3.0, 5.0, moved[:3, 3]), "drum": (8.0, 5.0, (10.0, 8.0, 0.4)),
        "tripod": (9.0, 3.0, tripod.position)}.items()}
    twin.record(Observation(cone.family, cone.global_id, moved, 0.004, 0.92, 240, station=1, frames=(3,)), T0,
                camera=cameras["cone"])
    twin.record(Observation(pallet.family, pallet.global_id, pallet.placement, 0.003, 0.95, 300, station=2), T0 + 5)
    twin.record(Observation("Steel_Drum_55gal", None, yaw_pose(10.0, 8.0, 0.0, 0.0), 0.006, 0.88, 150, station=3),
                T0 + 10, camera=cameras["drum"])
    twin.mark_missing(tripod.global_id, T0 + 15, station=4, camera=cameras["tripod"])
    zone = ZONES[0][0]
    for kind, when, data in [("hav.activity_started", 0, {"activity": "a1"}),
                             ("hav.eav_reached", 600, {"activity": "a1", "day_a8": 2.5, "limit": 2.5}),
                             ("hav.activity_ended", 900, {"activity": "a1", "day_a8": 2.6, "started": T0})]:
        twin.record_event(Event(kind, T0 + when, "worker-p1", "dev-1", {"zone": zone, "tool": "grinder", **data}))
    yield twin, {"cone": cone, "pallet": pallet, "tripod": tripod, "moved": moved, "cameras": cameras}
    twin.close()


def test_the_ifc_export_moves_deviating_elements_adds_new_ones_and_records_safety_events(day, tmp_path, site_ifc):
    twin, seen = day
    path = twin.export_ifc(tmp_path / "site_twin.ifc")
    again = load_ifc(path, cache_dir=tmp_path / "cache")
    assert np.allclose(again.element(seen["cone"].global_id).placement, seen["moved"], atol=1e-9)
    assert np.allclose(again.element(seen["pallet"].global_id).placement, seen["pallet"].placement, atol=1e-9)
    drum_id = next(gid for gid, s in twin.state().items() if s.status is ElementStatus.NEW)
    drum = again.element(drum_id)
    assert (drum.ifc_class, drum.family) == ("IfcBuildingElementProxy", "Steel_Drum_55gal")
    assert np.allclose(drum.placement, yaw_pose(10.0, 8.0, 0.0, 0.0))
    cone_pset = again.element(seen["cone"].global_id).psets["BIM2RDT_Observation"]
    assert cone_pset["Status"] == "deviating" and cone_pset["TolerancePreset"] == "temporary"
    assert cone_pset["TranslationMetres"] == pytest.approx(0.3) and cone_pset["Robot"] == "spot-1"
    assert again.element(seen["tripod"].global_id).psets["BIM2RDT_Observation"]["Status"] == "missing"
    assert "BIM2RDT_Observation" not in again.element(_element(again, "Steel_I-Beam_W12x26_A992").global_id).psets
    assert sorted(e.name for e in again.events) == ["HAV activity ended: grinding", "HAV activity started: grinding",
                                                    "HAV exposure action value (EAV) reached"]
    planned = {t.global_id for t in load_ifc(site_ifc, geometry=False).tasks}  # the site's work schedule
    assert len([t for t in again.tasks if t.global_id not in planned]) == 2
    assert _schema_errors(path) == _schema_errors(site_ifc)


def _schema_errors(path) -> list[str]:
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(ifcopenshell.open(str(path)), logger)
    return sorted(str(s["message"]).split("\n")[0] for s in logger.statements)


def test_the_bcf_has_one_topic_per_issue_with_the_camera_it_was_seen_from_and_a_snapshot(day, tmp_path):
    twin, seen = day
    path = twin.export_bcf(tmp_path / "issues.bcf")
    bcf = BcfXml.load(path)
    topics = {topic.topic.title.split(":")[0]: topic for topic in bcf.topics.values()}
    assert sorted(topics) == ["Deviating", "Missing", "New"]  # the pallet, as planned, has none
    states = twin.state()
    for label, key in [("Deviating", "cone"), ("Missing", "tripod"), ("New", "drum")]:
        topic = topics[label]
        (viewpoint,) = topic.viewpoints.values()
        (selected,) = viewpoint.get_selected_guids()
        assert states[selected].status.value == label.lower()
        camera = viewpoint.visualization_info.perspective_camera
        expected = seen["cameras"][key]
        assert np.allclose([camera.camera_view_point.x, camera.camera_view_point.y, camera.camera_view_point.z],
                           expected[:3, 3])
        assert np.allclose([camera.camera_direction.x, camera.camera_direction.y, camera.camera_direction.z],
                           expected[:3, 2])
        assert camera.camera_up_vector.z > 0
        image = cv2.imdecode(np.frombuffer(viewpoint.snapshot, np.uint8), cv2.IMREAD_COLOR)
        assert image.shape == (480, 640, 3) and image.std() > 10
    assert "0.300 m" in topics["Deviating"].topic.description and "temporary" in topics["Deviating"].topic.description
    bcf.close()


def test_a_snapshot_shows_the_object_in_its_status_colour_where_the_camera_looks(day, tmp_path):
    """The deviating cone is drawn orange at the image centre (the camera looks at it), and nowhere near the
    image corners."""
    twin, _ = day
    bcf = BcfXml.load(twin.export_bcf(tmp_path / "issues.bcf"))
    topic = next(t for t in bcf.topics.values() if t.topic.title.startswith("Deviating"))
    (viewpoint,) = topic.viewpoints.values()
    image = cv2.imdecode(np.frombuffer(viewpoint.snapshot, np.uint8), cv2.IMREAD_COLOR)
    hue = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
    orange = (hue[..., 0] > 8) & (hue[..., 0] < 20) & (hue[..., 1] > 120)
    ys, xs = np.nonzero(orange)
    assert len(xs) > 200
    assert abs(np.median(xs) - 320) < 60 and abs(np.median(ys) - 240) < 80
    bcf.close()


def test_the_json_export_holds_every_element_with_its_status_and_the_presets(day, tmp_path, site_model):
    twin, seen = day
    record = json.loads(twin.export_json(tmp_path / "twin.json").read_text())
    assert record["counts"]["deviating"] == 1 and record["counts"]["new"] == 1 and record["counts"]["missing"] == 1
    assert record["counts"]["as planned"] == 1
    assert record["counts"]["not observed"] == len(site_model.elements) - 3
    assert record["tolerances"]["structural"] == {"name": "structural", "translation": 0.01, "rotation_deg": 0.5}
    cone = next(e for e in record["elements"] if e["global_id"] == seen["cone"].global_id)
    assert cone["status"] == "deviating" and cone["deviation"]["translation"] == pytest.approx(0.3)
    assert np.allclose(cone["evidence"]["camera"], seen["cameras"]["cone"])


@pytest.fixture
def ifc2x3_model(tmp_path):
    path = tmp_path / "tiny2x3.ifc"
    path.write_text(IFC2X3_TEXT)
    return load_ifc(path, geometry=False)


def test_an_ifc2x3_twin_keeps_its_history_and_bcf_but_cannot_be_written_back(ifc2x3_model, tmp_path):
    (pallet,) = ifc2x3_model.elements
    pose = pallet.placement.copy()
    pose[0, 3] += 0.5
    with DigitalTwin.open(f"sqlite:///{tmp_path / 'twin.db'}", ifc2x3_model) as twin:
        assert twin.record(Observation(pallet.family, pallet.global_id, pose, 0.01, 0.9, 100), T0).status \
            is ElementStatus.DEVIATING
        assert len(twin.history(pallet.global_id)) == 2
        bcf = BcfXml.load(twin.export_bcf(tmp_path / "issues.bcf"))
        assert len(bcf.topics) == 1
        bcf.close()
        with pytest.raises(TwinError, match="cannot write the twin back into IFC: .*IFC2X3.*IFC4") as caught:
            twin.export_ifc(tmp_path / "twin.ifc")
        assert "\n" not in str(caught.value) and not (tmp_path / "twin.ifc").exists()
