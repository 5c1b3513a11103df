"""Progress from a twin's history: observed % at past dates (``state(at)``), each task's actual start and finish,
the S-curve, progress.json and the write-back into IfcTaskTime / IfcTask.Status, which IfcOpenShell's validator
accepts."""

from __future__ import annotations

import json
import shutil
from datetime import date, datetime, timezone

import ifcopenshell
import ifcopenshell.api.sequence
import ifcopenshell.validate
import pytest

from bim2rdt.bim import load_ifc
from bim2rdt.perception.observation import Observation
from bim2rdt.perception.structure import permanent_elements
from bim2rdt.sim.site import build_site_ifc
from bim2rdt.twin import DigitalTwin
from bim2rdt.twin.progress import TaskStatus
from bim2rdt.twin.progress_files import progress_of, progress_section, read_structure_statuses, write_progress

DAY = date(2026, 12, 6)
T1 = datetime(2026, 12, 6, 7, 30, tzinfo=timezone.utc).timestamp()
T2 = datetime(2026, 12, 6, 9, 30, tzinfo=timezone.utc).timestamp()


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    folder = tmp_path_factory.mktemp("progress-site")
    path = build_site_ifc(folder / "site.ifc", day=DAY)
    return load_ifc(path, cache_dir=folder / "cache")


def named(model, *prefixes):
    return [el for el in model.elements if el.name and el.name.startswith(prefixes)]


def seen(element):
    return Observation(element.family, element.global_id, element.placement, 0.004, 0.9, 250, score=0.8)


@pytest.fixture
def day_twin(site, tmp_path):
    """The cones seen in place at 07:30, the scaffold at 09:30, the tripod's place seen empty at 09:30; the
    structure as planned but the north-east partition not built (judged at 07:30)."""
    twin = DigitalTwin.open(f"sqlite:///{tmp_path / 'twin.db'}", site)
    for cone in named(site, "Traffic_Cone"):
        twin.record(seen(cone), T1)
    twin.record(seen(named(site, "Scaffold")[0]), T2)
    twin.mark_missing(named(site, "Survey_Tripod")[0].global_id, T2)
    structure = {el.global_id: "not built" if el.name == "Interior Wall - Partition NE" else "as planned"
                 for el in permanent_elements(site)}
    yield twin, structure
    twin.close()


def rows(record):
    return {task["identification"]: task for task in record["tasks"]}


def test_progress_json_and_the_write_back_follow_the_twin_and_the_ifc_validates(site, day_twin, tmp_path):
    twin, structure = day_twin
    twin_ifc = tmp_path / "site_twin.ifc"
    shutil.copy(site.path, twin_ifc)
    files = write_progress(twin, tmp_path, twin_ifc=twin_ifc, structure=structure,
                           structure_time=datetime.fromtimestamp(T1, timezone.utc))
    record = json.loads(files.progress_json.read_text())
    assert datetime.fromisoformat(record["date"]) == datetime.fromtimestamp(T2, timezone.utc)
    task = rows(record)
    assert (task["S.5"]["status"], task["T.4"]["status"], task["T.1"]["status"]) == ("behind", "ahead", "complete")
    assert task["T.3"]["status"] == "not started" and task["T.2"]["status"] == "unknown"
    assert task["T.1"]["products"] == {"as planned": 3, "deviating": 0, "not built": 0, "not observed": 0}

    written = ifcopenshell.open(str(files.ifc))
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(written, logger, express_rules=True)
    assert logger.statements == []
    cones = written.by_guid(task["T.1"]["global_id"])
    assert cones.Status == "complete" and cones.TaskTime.Completion == pytest.approx(1.0)
    assert datetime.fromisoformat(cones.TaskTime.ActualStart).replace(tzinfo=timezone.utc).timestamp() == T1
    assert datetime.fromisoformat(cones.TaskTime.ActualFinish).replace(tzinfo=timezone.utc).timestamp() == T1
    scaffold = written.by_guid(task["T.4"]["global_id"]).TaskTime
    assert datetime.fromisoformat(scaffold.ActualStart).replace(tzinfo=timezone.utc).timestamp() == T2
    partition = written.by_guid(task["S.5"]["global_id"])
    assert partition.Status == "behind" and partition.TaskTime.Completion is None
    assert partition.TaskTime.ActualStart is None
    assert partition.TaskTime.ScheduleFinish == "2026-12-05T17:00:00"  # the plan is kept


def test_the_s_curve_observes_nothing_before_the_first_observation_and_more_after_each(site, day_twin, tmp_path):
    twin, structure = day_twin
    files = write_progress(twin, tmp_path, structure=structure,
                           structure_time=datetime.fromtimestamp(T1, timezone.utc))
    assert len(json.loads(files.curve_json.read_text())["points"]) == len(files.curve)
    observed = [(p.date.timestamp(), p.observed_percent) for p in files.curve]
    assert all(value is None for when, value in observed if when < T1)
    at_t1 = next(value for when, value in observed if when == T1)
    at_t2 = next(value for when, value in observed if when == T2)
    assert 0 < at_t1 < at_t2 < 100  # the scaffold came in at 09:30; the partition is never built
    assert all(value is None for when, value in observed if when > T2)
    planned = [p.planned_percent for p in files.curve]
    assert planned == sorted(planned) and planned[0] == 0.0 and planned[-1] == 100.0


def test_at_a_past_date_the_twin_as_it_was_gives_the_progress(site, day_twin):
    twin, _ = day_twin
    progress, _, groups = progress_of(twin, at=datetime.fromtimestamp(T1 + 60, timezone.utc))
    task = rows(progress.to_dict())
    assert not groups and task["T.1"]["status"] == "complete" and task["T.4"]["status"] == "unknown"
    later, _, _ = progress_of(twin)
    assert later.task(task["T.4"]["global_id"]).status is TaskStatus.AHEAD


def test_the_report_section_embeds_the_table_the_s_curve_and_the_structure(site, day_twin, tmp_path):
    twin, structure = day_twin
    assert progress_section(tmp_path) is None
    write_progress(twin, tmp_path, structure=structure)
    page = progress_section(tmp_path)
    assert page.count("data:image/png;base64,") == 2 and "Partition north-east room" in page
    assert page.count("#d62728;color:white'>behind<") == 1 and page.count(">ahead<") == 1


def test_a_model_without_a_schedule_gets_progress_by_storey_and_by_class(tmp_path, site):
    plain = ifcopenshell.open(str(site.path))  # the site with its schedule removed
    for schedule in plain.by_type("IfcWorkSchedule"):
        ifcopenshell.api.sequence.remove_work_schedule(plain, work_schedule=schedule)
    plain.write(str(tmp_path / "plain.ifc"))
    model = load_ifc(tmp_path / "plain.ifc")
    with DigitalTwin.open(f"sqlite:///{tmp_path / 'twin.db'}", model) as twin:
        wall = named(model, "Exterior Wall - South")[0]
        progress, curve, groups = progress_of(twin, structure={wall.global_id: "as planned"})
        assert write_progress(twin, tmp_path) is None and not (tmp_path / "progress.json").exists()
    assert progress is None and curve == []
    by = {(g.by, g.name): g for g in groups}
    assert by[("storey", "Ground Floor")].products["as planned"] == 1
    walls = by[("class", "IfcWall")]
    assert walls.products == {"as planned": 1, "deviating": 0, "not built": 0, "not observed": 6}
    assert walls.observed_percent == pytest.approx(100 * 18.0 / (2 * 18.0 + 2 * 12.6 + 3.15 + 3.465 + 0.54), rel=1e-3)


def test_structure_json_is_read_as_statuses_and_a_bad_one_is_one_line(tmp_path):
    from bim2rdt.twin import TwinError

    assert read_structure_statuses(tmp_path / "absent.json") == {}
    good = tmp_path / "structure.json"
    good.write_text(json.dumps([{"global_id": "a", "ifc_class": "IfcWall", "status": "not built", "coverage": 0.8}]))
    assert read_structure_statuses(good) == {"a": "not built"}
    good.write_text(json.dumps({"a": 1}))
    with pytest.raises(TwinError, match="structure.json: not a list"):
        read_structure_statuses(good)
