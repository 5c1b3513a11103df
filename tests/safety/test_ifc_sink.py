"""HAV events written into the twin's IFC: IfcEvent/IfcTask with exposure psets, linked to the work zone."""

from __future__ import annotations

import pytest

from bim2rdt.bim import TwinWriter, load_ifc
from bim2rdt.safety import HavMonitor, ListSink, MonitorConfig
from bim2rdt.safety.ifc_sink import IfcSink
from bim2rdt.sim.site import build_site_ifc

from hav_helpers import T0, Clock, feed, plan_batches

# a compressed day: magnitudes far above real tools so EAV and ELV come within minutes of samples
PLAN = [("idle", 3), ("grinder", 20), ("idle", 4), ("hammer_drill", 60), ("idle", 4), ("breaker", 150), ("idle", 4)]
AHV = {"grinder": 20.0, "hammer_drill": 60.0, "breaker": 60.0}
ZONE = "Work Zone A - Drilling"


@pytest.fixture(scope="module")
def day_events(tmp_path_factory):
    sink = ListSink()
    monitor = HavMonitor(tmp_path_factory.mktemp("hav"), "secret", [sink], MonitorConfig(), Clock())
    items, start = plan_batches("dev-1", PLAN, a_hv=AHV), 0.0
    for tool, seconds in PLAN:  # the wearable's status names the tool in hand (idle keeps the last one)
        if tool != "idle":
            monitor.start_session("dev-1", "olga", tool, "handle", ZONE)
        feed(monitor, [b for b in items if start <= b.device_time - T0 < start + seconds])
        start += seconds
    monitor.close()
    return sink.events


def write_twin(ifc_in, ifc_out, events, **session):
    model = load_ifc(ifc_in, geometry=False)
    writer = TwinWriter(model)
    sink = IfcSink(writer, model)
    for event in events:
        sink.emit(event if not session else event.__class__(**{**vars(event), "data": {**event.data, **session}}))
    writer.save(ifc_out)
    return model, load_ifc(ifc_out, geometry=False)


def test_the_written_ifc_has_the_events_and_tasks_linked_to_the_work_zone(tmp_path, day_events):
    site = build_site_ifc(tmp_path / "site.ifc")
    model, twin = write_twin(site, tmp_path / "twin.ifc", day_events)
    zone = next(z.global_id for z in model.zones if z.name == ZONE)
    names = [e.name for e in sorted(twin.events, key=lambda e: e.start)]
    assert [n.split(":")[0] for n in names] == [
        "HAV activity started", "HAV activity ended", "HAV activity started", "HAV exposure action value (EAV) reached",
        "HAV activity ended", "HAV activity started", "HAV exposure limit value (ELV) reached", "HAV activity ended"]
    assert all(e.related == (zone,) for e in twin.events)
    intervention = next(t for t in twin.tasks if t.name.startswith("Safety instructor intervention"))
    eav = next(e for e in twin.events if "EAV" in e.name)
    assert intervention.after == (eav.global_id,) and intervention.related == (zone,)
    assert intervention.start == eav.start
    sensed = [t for t in twin.tasks if t.name.endswith("(sensed)")]
    assert [t.name for t in sensed] == ["grinding (sensed)", "hammer drilling (sensed)", "breaking (sensed)"]
    assert all(t.finish > t.start for t in sensed)


def test_records_carry_exposure_figures_and_the_pseudonym_only(tmp_path, day_events):
    site = build_site_ifc(tmp_path / "site.ifc")
    _, twin = write_twin(site, tmp_path / "twin.ifc", day_events)
    last_end = max((e for e in twin.events if e.name.startswith("HAV activity ended")), key=lambda e: e.start)
    pset = last_end.psets["BIM2RDT_Event"]
    ended = [e for e in day_events if e.kind == "hav.activity_ended"][-1]
    assert pset["Pseudonym"] == ended.subject and pset["Pseudonym"].startswith("w-")
    assert pset["DailyExposureA8"] == pytest.approx(ended.data["day_a8"])
    assert pset["DailyExposureA8"] > 5.0 and pset["RiskFlag"] == "above_elv"
    assert pset["AHv"] == pytest.approx(60.0, rel=0.05) and pset["ExposurePoints"] > 400
    elv = next(e for e in twin.events if "ELV" in e.name).psets["BIM2RDT_Event"]
    assert (elv["Limit"], elv["LimitValue"]) == ("ELV", 5.0)
    assert b"olga" not in (tmp_path / "twin.ifc").read_bytes()


def test_the_activity_reuses_the_work_schedule_vocabulary(tmp_path, day_events, samples):
    scheduled = samples / "construction_scheduling_task.ifc"
    model = load_ifc(scheduled, geometry=False)
    wall = next(t for t in model.tasks if t.name == "Wall #2")
    _, twin = write_twin(scheduled, tmp_path / "twin.ifc", day_events, zone=wall.related[0])
    sensed = [t for t in twin.tasks if t.name.endswith("(sensed)")]
    assert sensed and all(t.name.startswith("Wall #2: ") for t in sensed)
    assert all(t.psets["BIM2RDT_Task"]["ScheduleTask"] == wall.global_id for t in sensed)
    import ifcopenshell

    ifc = ifcopenshell.open(str(tmp_path / "twin.ifc"))
    nested = {child.GlobalId for rel in ifc.by_guid(wall.global_id).IsNestedBy for child in rel.RelatedObjects}
    assert {t.global_id for t in sensed} <= nested
