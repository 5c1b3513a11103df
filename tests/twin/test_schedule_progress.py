"""Progress against the embedded site's schedule from a plain {GlobalId: status} mapping: planned % linear over the
scheduled dates (or Completion), observed % by quantity, the statuses, the roll-up of summary tasks."""

from __future__ import annotations

import json
from dataclasses import replace
from datetime import date, datetime, timezone

import pytest

from bim2rdt.bim import load_ifc
from bim2rdt.bim.quantities import mesh_volume_area, product_quantities
from bim2rdt.bim.schedule import read_work_schedule
from bim2rdt.sim.site import build_site_ifc
from bim2rdt.twin.progress import (PartlyBuilt, TaskStatus, built_share, merge_statuses, product_state,
                                   schedule_progress)
from bim2rdt.twin.progress_files import read_structure_statuses

DAY = date(2026, 12, 6)
NOON = datetime(2026, 12, 6, 12, 0, tzinfo=timezone.utc)


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    folder = tmp_path_factory.mktemp("scheduled-site")
    path = build_site_ifc(folder / "site.ifc", day=DAY)
    model = load_ifc(path, cache_dir=folder / "cache")
    schedule = read_work_schedule(path)
    products = [p for task in schedule.tasks for p in task.products]
    return model, schedule, product_quantities(model, None, products)


def by_id(schedule, identification):
    return next(t for t in schedule.tasks if t.identification == identification)


def statuses_of(model, schedule, **states):
    """Every product of the tasks named by identification gets the given status."""
    found = {}
    for identification, status in states.items():
        for global_id in by_id(schedule, identification.replace("_", ".")).products:
            found[global_id] = status
    return found


def test_the_schedule_is_read_as_two_summary_tasks_of_nested_tasks_with_products_and_sequences(site):
    model, schedule, _ = site
    assert [t.identification for t in schedule.roots] == ["S", "T"]
    structure = by_id(schedule, "S")
    assert structure.is_summary and [schedule.task(c).identification for c in structure.children] == [
        "S.1", "S.2", "S.3", "S.4", "S.5"]
    names = {model.element(g).name for g in by_id(schedule, "S.2").products}
    assert names == {"Exterior Wall - South", "Exterior Wall - East", "Exterior Wall - North", "Exterior Wall - West"}
    assert by_id(schedule, "S.3").predecessors == (by_id(schedule, "S.2").global_id,)
    assert by_id(schedule, "S.5").schedule_finish == datetime(2026, 12, 5, 17, tzinfo=timezone.utc)


def test_a_closed_box_mesh_has_its_volume_and_walls_are_measured_by_volume(site):
    model, schedule, quantities = site
    assert quantities.kind == "volume"
    south = next(g for g in by_id(schedule, "S.2").products if model.element(g).name == "Exterior Wall - South")
    assert quantities.values[south] == pytest.approx(20.0 * 0.3 * 3.0, rel=1e-6)
    assert mesh_volume_area(*model.mesh(south))[1] == pytest.approx(2 * (20 * 0.3 + 20 * 3 + 0.3 * 3), rel=1e-6)


def test_the_simulated_day_has_the_partition_behind_and_the_scaffold_ahead(site):
    model, schedule, quantities = site
    built = statuses_of(model, schedule, S_1="as planned", S_2="as planned", S_3="as planned", S_4="deviating",
                        T_1="as planned", T_2="deviating", T_4="as planned")
    built |= statuses_of(model, schedule, S_5="not built", T_3="missing")
    progress = schedule_progress(schedule, built, quantities, NOON)
    status = {row.task.identification: row.status for row in progress.tasks}
    assert status == {"S": TaskStatus.IN_PROGRESS, "S.1": TaskStatus.COMPLETE, "S.2": TaskStatus.COMPLETE,
                      "S.3": TaskStatus.COMPLETE, "S.4": TaskStatus.COMPLETE, "S.5": TaskStatus.BEHIND,
                      "T": TaskStatus.IN_PROGRESS, "T.1": TaskStatus.COMPLETE, "T.2": TaskStatus.COMPLETE,
                      "T.3": TaskStatus.NOT_STARTED, "T.4": TaskStatus.AHEAD}
    partition = progress.task(by_id(schedule, "S.5").global_id)
    assert (partition.planned_percent, partition.observed_percent) == (100.0, 0.0)
    assert partition.products == {"as planned": 0, "deviating": 0, "not built": 1, "not observed": 0}
    scaffold = progress.task(by_id(schedule, "T.4").global_id)
    assert (scaffold.planned_percent, scaffold.observed_percent) == (0.0, 100.0)
    structure = progress.task(by_id(schedule, "S").global_id)
    partition_volume = quantities.values[by_id(schedule, "S.5").products[0]]
    assert structure.observed_percent == pytest.approx(
        100 * (structure.total_quantity - partition_volume) / structure.total_quantity)
    assert structure.products["not built"] == 1 and sum(structure.products.values()) == 15  # 0.4 % by volume


def test_planned_percent_is_linear_over_the_scheduled_dates_and_completion_overrides_it(site):
    _, schedule, quantities = site
    cones = by_id(schedule, "T.1")  # 2026-12-04 07:00 .. 2026-12-05 17:00: 34 hours
    halfway = datetime(2026, 12, 5, 0, 0, tzinfo=timezone.utc)
    row = schedule_progress(schedule, {}, quantities, halfway).task(cones.global_id)
    assert row.planned_percent == pytest.approx(100 * 17 / 34) and row.status is TaskStatus.UNKNOWN
    tasks = tuple(replace(t, completion=0.25) if t.global_id == cones.global_id else t for t in schedule.tasks)
    row = schedule_progress(replace(schedule, tasks=tasks), {}, quantities, halfway).task(cones.global_id)
    assert row.planned_percent == pytest.approx(25.0)


def test_a_gap_the_products_not_observed_could_close_is_not_behind(site):
    model, schedule, quantities = site
    columns = by_id(schedule, "S.3").products
    some = {g: "as planned" for g in columns[:2]}  # four not observed: they may stand
    row = schedule_progress(schedule, some, quantities, NOON).task(by_id(schedule, "S.3").global_id)
    assert row.observed_percent == pytest.approx(100 * 2 / 6) and row.status is TaskStatus.IN_PROGRESS
    all_seen = some | {g: "not built" for g in columns[2:]}
    row = schedule_progress(schedule, all_seen, quantities, NOON).task(by_id(schedule, "S.3").global_id)
    assert row.status is TaskStatus.BEHIND


def test_the_threshold_decides_behind_and_ahead(site):
    model, schedule, quantities = site
    cones = by_id(schedule, "T.1")
    seen = {cones.products[0]: "as planned", cones.products[1]: "not built", cones.products[2]: "not built"}
    at = datetime(2026, 12, 4, 17, 0, tzinfo=timezone.utc)  # 10 of 34 hours: 29.4 % planned, 33.3 % observed
    assert schedule_progress(schedule, seen, quantities, at).task(cones.global_id).status is TaskStatus.IN_PROGRESS
    loose = schedule_progress(schedule, seen, quantities, at, ahead_percent=1.0)
    assert loose.task(cones.global_id).status is TaskStatus.AHEAD


def test_twin_verdicts_map_to_built_not_built_and_not_observed_and_a_later_source_wins_where_it_says_something():
    assert [product_state(s) for s in ("as planned", "deviating", "missing", "not built", "new", "unverified", None)] \
        == ["as planned", "deviating", "not built", "not built", "not observed", "not observed", "not observed"]
    merged = merge_statuses({"a": "missing", "b": "as planned"}, {"a": "not observed", "b": "not built", "c": "x"})
    assert merged == {"a": "not built", "b": "not built", "c": "not observed"}


def test_progress_json_has_the_contracted_shape(site):
    model, schedule, quantities = site
    record = schedule_progress(schedule, {}, quantities, NOON).to_dict()
    assert set(record) == {"schedule", "date", "tasks"} and set(record["schedule"]) == {"global_id", "name"}
    assert datetime.fromisoformat(record["date"]) == NOON
    assert set(record["tasks"][0]) == {"global_id", "name", "identification", "planned_start", "planned_finish",
                                       "planned_percent", "observed_percent", "status", "products", "children"}
    assert set(record["tasks"][0]["products"]) == {"as planned", "deviating", "not built", "not observed"}
    assert record["tasks"][0]["children"] == list(by_id(schedule, "S").children)


def test_a_partly_built_product_counts_its_quantity_by_the_share_built_and_its_task_stays_behind(site):
    """The structure judge's partly built wall ("deviating", built on 40 % of its face) counts 40 % of its volume,
    not all of it: the partition's task is behind at 40 %, and the structure's summary counts the same share."""
    model, schedule, quantities = site
    partition = by_id(schedule, "S.5").products[0]
    states = statuses_of(model, schedule, S_1="as planned", S_2="as planned", S_3="as planned", S_4="as planned")
    progress = schedule_progress(schedule, states | {partition: PartlyBuilt("deviating", 0.4)}, quantities, NOON)
    row = progress.task(by_id(schedule, "S.5").global_id)
    assert row.observed_percent == pytest.approx(40.0) and row.status is TaskStatus.BEHIND
    assert row.products["deviating"] == 1 and row.built_quantity == pytest.approx(0.4 * quantities.values[partition])
    whole = schedule_progress(schedule, states | {partition: "deviating"}, quantities, NOON)
    assert whole.task(by_id(schedule, "S.5").global_id).status is TaskStatus.COMPLETE  # a plain status: all built
    summary = progress.task(by_id(schedule, "S").global_id)
    assert summary.built_quantity == pytest.approx(summary.total_quantity - 0.6 * quantities.values[partition])


def test_a_partly_built_state_merges_prints_and_counts_as_its_status_and_needs_a_built_status_and_a_share():
    state = PartlyBuilt("deviating", 0.25)
    assert state == "deviating" and str(state) == "deviating" and json.dumps({"a": state}) == '{"a": "deviating"}'
    assert merge_statuses({"a": "as planned"}, {"a": state})["a"].built == 0.25
    assert [built_share(s) for s in (state, "as planned", "deviating", "not built", "not observed", None)] == [
        0.25, 1.0, 1.0, 0.0, 0.0, 0.0]
    for status, share in (("not built", 0.5), ("deviating", 1.5), ("deviating", -0.1)):
        with pytest.raises(ValueError):
            PartlyBuilt(status, share)


def test_structure_json_built_share_under_one_reads_as_partly_built(tmp_path):
    path = tmp_path / "structure.json"
    path.write_text(json.dumps([{"global_id": "a", "status": "deviating", "built_share": 0.3},
                                {"global_id": "b", "status": "deviating", "built_share": 1.0},
                                {"global_id": "c", "status": "not built", "built_share": 0.0},
                                {"global_id": "d", "status": "as planned"}]))
    states = read_structure_statuses(path)
    assert states == {"a": "deviating", "b": "deviating", "c": "not built", "d": "as planned"}
    assert [built_share(states[k]) for k in "abcd"] == [0.3, 1.0, 0.0, 1.0]
    assert isinstance(states["a"], PartlyBuilt) and not isinstance(states["b"], PartlyBuilt)
