"""Progress on a real recording: PCL's office1 frame against office1.ifc with a work schedule added here through
``ifcopenshell.api.sequence`` (walls; the desk; a 1 m partition across the clear floor in front of the door, which
the room does not have). ``verify`` writes progress.json from its twin (the desk's verdict is the real chain's);
the structure's judgements enter through structure.json, as the structure judge writes it: the walls as planned,
the partition not built."""

from __future__ import annotations

import json

import ifcopenshell
import ifcopenshell.api.geometry
import ifcopenshell.api.root
import ifcopenshell.api.sequence
import ifcopenshell.api.spatial
import ifcopenshell.util.representation
import ifcopenshell.validate
import numpy as np
import pytest
from typer.testing import CliRunner

from bim2rdt.bim import load_ifc
from bim2rdt.cli import app
from bim2rdt.twin import DigitalTwin
from bim2rdt.twin.progress_files import write_progress

runner = CliRunner()
PARTITION = "Partition across the floor"


def scheduled_office(source, target):
    """office1.ifc plus the partition (x 1.0..2.4 m at y -0.9 m, 1 m high: the floor there is clear) and a
    schedule: walls in January, the desk on 2 February, the partition on 3-4 February (all due by the frame's
    date, the run's clock)."""
    ifc = ifcopenshell.open(str(source))
    storey = ifc.by_type("IfcBuildingStorey")[0]
    body = ifcopenshell.util.representation.get_context(ifc, "Model", "Body", "MODEL_VIEW")
    partition = ifcopenshell.api.root.create_entity(ifc, ifc_class="IfcWall", name=PARTITION)
    ifcopenshell.api.spatial.assign_container(ifc, products=[partition], relating_structure=storey)
    shape = ifcopenshell.api.geometry.add_wall_representation(ifc, context=body, length=1.4, height=1.0,
                                                              thickness=0.1)
    ifcopenshell.api.geometry.assign_representation(ifc, product=partition, representation=shape)
    placement = np.eye(4)
    placement[:3, 3] = (1.0, -0.9, 0.0)
    ifcopenshell.api.geometry.edit_object_placement(ifc, product=partition, matrix=placement, is_si=True)
    schedule = ifcopenshell.api.sequence.add_work_schedule(ifc, name="Office fit-out")
    walls = [w for w in ifc.by_type("IfcWall") if w != partition]
    desk = next(e for e in ifc.by_type("IfcFurniture") if e.Name == "Desk")
    for identification, name, products, start, finish in (
            ("A", "Walls", walls, "2026-01-05T07:00:00", "2026-01-16T17:00:00"),
            ("B", "Desk", [desk], "2026-02-02T07:00:00", "2026-02-02T17:00:00"),
            ("C", "Partition", [partition], "2026-02-03T07:00:00", "2026-02-04T17:00:00")):
        task = ifcopenshell.api.sequence.add_task(ifc, work_schedule=schedule, name=name,
                                                  identification=identification)
        for product in products:
            ifcopenshell.api.sequence.assign_product(ifc, relating_product=product, related_object=task)
        task_time = ifcopenshell.api.sequence.add_task_time(ifc, task=task)
        task_time.ScheduleStart, task_time.ScheduleFinish = start, finish
    ifc.write(str(target))
    return target


@pytest.fixture(scope="module")
def verified(sensors, tmp_path_factory):
    folder = tmp_path_factory.mktemp("office-progress")
    model_path = scheduled_office(sensors / "pcl" / "office1.ifc", folder / "office1.ifc")
    truth = json.loads((sensors / "pcl" / "office1_truth.json").read_text())
    result = runner.invoke(app, ["verify", str(model_path), str(sensors / "pcl" / "office1.pcd"), "--prior",
                                 "1.30,-4.55,1.38,82", "--depth-correction",
                                 ",".join(str(v) for v in truth["depth_correction"]["g"]), "--out",
                                 str(folder / "out"), "--json"])
    assert result.exit_code == 0, result.output
    return folder, model_path, json.loads(result.output)


def tasks(record):
    return {task["name"]: task for task in record["tasks"]}


def test_verify_writes_progress_json_with_the_desks_task_complete_from_its_real_verdict(verified):
    folder, _, summary = verified
    assert summary["localized"] == 1 and summary["verdicts"]["as planned"] == 5  # the partition misleads nothing
    record = json.loads((folder / "out" / "progress.json").read_text())
    assert record["schedule"]["name"] == "Office fit-out"
    desk = tasks(record)["Desk"]
    assert desk["status"] == "complete" and desk["observed_percent"] == 100.0
    assert desk["products"] == {"as planned": 1, "deviating": 0, "not built": 0, "not observed": 0}
    walls = tasks(record)["Walls"]  # judged by verify's own structure judge (structure.json in the folder)
    assert walls["status"] in ("complete", "in progress") and walls["products"]["as planned"] >= 1, walls


def test_with_the_structures_judgements_the_walls_are_complete_and_the_partition_is_behind(verified, tmp_path):
    folder, model_path, _ = verified
    model = load_ifc(model_path)
    structure = [{"global_id": el.global_id, "ifc_class": el.ifc_class,
                  "status": "not built" if el.name == PARTITION else "as planned"}
                 for el in model.elements if el.ifc_class == "IfcWall"]
    (tmp_path / "structure.json").write_text(json.dumps(structure))
    result = runner.invoke(app, ["progress", str(model_path), "--url", str(folder / "out" / "twin.db"),
                                 "--structure", str(tmp_path / "structure.json"), "--json"])
    assert result.exit_code == 0, result.output
    row = tasks(json.loads(result.output))
    assert [row[name]["status"] for name in ("Walls", "Desk", "Partition")] == ["complete", "complete", "behind"]
    assert row["Walls"]["products"]["as planned"] == 3 and row["Partition"]["products"]["not built"] == 1
    assert (row["Partition"]["planned_percent"], row["Partition"]["observed_percent"]) == (100.0, 0.0)

    with DigitalTwin.open(f"sqlite:///{folder / 'out' / 'twin.db'}", model, create=False) as twin:
        written = write_progress(twin, tmp_path, twin_ifc=folder / "out" / "twin.ifc",
                                 structure={s["global_id"]: s["status"] for s in structure})
    ifc = ifcopenshell.open(str(written.ifc))
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(ifc, logger, express_rules=True)
    assert logger.statements == []
    assert {t.Name: t.Status for t in ifc.by_type("IfcTask")} == {"Walls": "complete", "Desk": "complete",
                                                                   "Partition": "behind"}


def test_progress_without_a_schedule_is_by_storey_and_by_class(verified, sensors):
    folder, _, _ = verified
    result = runner.invoke(app, ["progress", str(sensors / "pcl" / "office1.ifc"), "--url",
                                 str(folder / "out" / "twin.db"), "--json"])
    assert result.exit_code == 0, result.output
    record = json.loads(result.output)
    assert record["schedule"] is None
    groups = {(g["by"], g["name"]) for g in record["groups"]}
    assert ("class", "IfcWall") in groups and any(by == "storey" for by, _ in groups)
