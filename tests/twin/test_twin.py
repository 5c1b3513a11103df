"""DigitalTwin on SQLite and PostgreSQL: status and deviation per element, the append-only history, the state at
a past time rebuilt by replay (and equal to the live state), new and missing objects, safety events, bad input."""

from __future__ import annotations

import dataclasses
import math
import signal
from pathlib import Path

import numpy as np
import pytest
import sqlalchemy as sa

from bim2rdt.bus import Event
from bim2rdt.perception.camera import look_at
from bim2rdt.perception.observation import Observation
from bim2rdt.sim.site import ZONES, yaw_pose
from bim2rdt.twin import MISSING, OBSERVATION, SAFETY, STATUS, DigitalTwin, ElementStatus, TwinError, TwinSink

from twin_helpers import SYMMETRY, T0, family_mesh
from twin_workers import safety_group


@pytest.fixture
def twin(twin_url, site_model):
    with DigitalTwin.open(twin_url, site_model, symmetry=SYMMETRY, robot="spot-1", family_mesh=family_mesh) as t:
        yield t


def _element(model, family, index=0):
    return [el for el in model.elements if el.family == family][index]


def _seen(element, pose=None, fitness=0.9, **extra) -> Observation:
    pose = element.placement if pose is None else pose
    return Observation(element.family, element.global_id, pose, 0.004, fitness, 250, score=0.8,
                       detector="geometric", **extra)


def _moved(element, dx=0.0, dy=0.0, yaw_deg=0.0):
    T = element.placement.copy()
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    T[:3, :3] = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ T[:3, :3]
    T[:2, 3] += (dx, dy)
    return T


def _statuses(states):
    return {gid: s.status for gid, s in states.items()}


# ---- status per element ---------------------------------------------------------------------------------------

def test_every_bim_element_starts_not_observed(twin, site_model):
    states = twin.state()
    assert set(states) == {el.global_id for el in site_model.elements}
    assert {s.status for s in states.values()} == {ElementStatus.NOT_OBSERVED}


def test_an_object_where_the_bim_puts_it_is_as_planned_with_its_evidence_and_robot(twin, site_model):
    cone = _element(site_model, "Traffic_Cone_Orange_70cm")
    camera = look_at((3.0, 5.0, 1.1), cone.position)
    state = twin.record(_seen(cone, _moved(cone, dx=0.02), station=3, frames=(7, 8)), T0, camera=camera)
    assert state.status is ElementStatus.AS_PLANNED
    assert state.deviation.translation == pytest.approx(0.02)
    assert state.tolerance.name == "temporary"
    assert (state.evidence.station, state.evidence.frames, state.evidence.time) == (3, (7, 8), T0)
    assert np.allclose(state.evidence.camera, camera)
    assert state.robot == "spot-1" and state.fit.fitness == 0.9 and state.fit.detector == "geometric"
    assert twin.state()[cone.global_id] == state


def test_beyond_the_preset_an_object_is_deviating_and_a_column_is_held_to_a_centimetre(twin, site_model):
    cone = _element(site_model, "Traffic_Cone_Orange_70cm")
    column = next(el for el in site_model.elements if el.ifc_class == "IfcColumn")
    assert twin.record(_seen(cone, _moved(cone, dx=0.08)), T0).status is ElementStatus.DEVIATING
    column_state = twin.record(_seen(column, _moved(column, dy=0.02)), T0, robot="spot-2")
    assert column_state.status is ElementStatus.DEVIATING
    assert column_state.tolerance.name == "structural" and column_state.robot == "spot-2"
    assert twin.record(_seen(column, _moved(column, dy=0.005)), T0 + 1).status is ElementStatus.AS_PLANNED


def test_a_cone_turned_by_a_quarter_is_as_planned_but_a_crate_is_not(twin, site_model):
    cone = _element(site_model, "Traffic_Cone_Orange_70cm")
    crate = _element(site_model, "Wooden_Crate_1200x800x600")
    cone_state = twin.record(_seen(cone, _moved(cone, yaw_deg=91.0)), T0)
    assert cone_state.status is ElementStatus.AS_PLANNED and cone_state.deviation.yaw_deg == pytest.approx(1.0)
    crate_state = twin.record(_seen(crate, _moved(crate, yaw_deg=91.0)), T0)
    assert crate_state.status is ElementStatus.DEVIATING and crate_state.deviation.yaw_deg == pytest.approx(91.0)


def test_a_poor_fit_is_unverified_however_close_it_lands(twin, site_model):
    pallet = _element(site_model, "Pallet_Wood_EUR")
    state = twin.record(_seen(pallet, fitness=0.3), T0)
    assert state.status is ElementStatus.UNVERIFIED and state.deviation.translation == pytest.approx(0.0)


def test_an_observation_its_observer_could_not_judge_stays_unverified_with_the_reason(twin, site_model):
    """The mission's verdict on a view blind along one axis (issue 13) is kept, not overruled by a pose that
    merely stayed where the BIM put it."""
    pallet = _element(site_model, "Pallet_Wood_EUR")
    seen = _seen(pallet)
    blind = dataclasses.replace(seen, status=ElementStatus.UNVERIFIED, shift=0.0, yaw_deg=0.0, tilt_deg=0.0,
                                upright_bias=0.9, reason="along x (the view does not pin the pose down there)")
    assert twin.record(blind, T0).status is ElementStatus.UNVERIFIED
    observation = [e for e in twin.history(pallet.global_id) if e.kind == "observation"][-1]
    assert observation.data["reason"].startswith("along x")
    assert twin.record(_seen(pallet), T0 + 1).status is ElementStatus.AS_PLANNED  # a plain record is judged


def test_a_fit_with_no_inlier_is_recorded_unverified_without_an_rmse_and_exports(twin, site_model, tmp_path):
    """A partial view behind a wall can leave no point on the fitted model: rmse inf, fitness 0. That is a
    sighting the twin keeps (unverified, rmse None in the store), not bad input; an infinite rmse with a
    fitness above 0 still is."""
    pallet = _element(site_model, "Pallet_Wood_EUR")
    blind = Observation(pallet.family, pallet.global_id, pallet.placement, math.inf, 0.0, 40)
    state = twin.record(blind, T0)
    assert state.status is ElementStatus.UNVERIFIED and state.fit.rmse is None
    assert twin.state()[pallet.global_id].fit.rmse is None
    with pytest.raises(TwinError, match="inf only with fitness 0"):
        twin.record(Observation(pallet.family, pallet.global_id, pallet.placement, math.inf, 0.4, 40), T0 + 1)
    assert twin.export_json(tmp_path / "twin.json").is_file() and twin.export_ifc(tmp_path / "twin.ifc").is_file()


def test_an_object_the_bim_lacks_is_new_and_seen_again_nearby_it_is_the_same_object(twin, site_model):
    first = twin.record(Observation("Steel_Drum_55gal", None, yaw_pose(10.0, 8.0, 0.0, 0.0), 0.01, 0.9, 120), T0)
    assert first.status is ElementStatus.NEW and not first.in_bim and len(first.global_id) == 22
    again = twin.record(Observation("Steel_Drum_55gal", None, yaw_pose(10.3, 8.1, 0.0, 0.0), 0.01, 0.9, 120), T0 + 5)
    other = twin.record(Observation("Steel_Drum_55gal", None, yaw_pose(13.0, 8.0, 0.0, 0.0), 0.01, 0.9, 120), T0 + 6)
    assert again.global_id == first.global_id and other.global_id != first.global_id
    assert np.allclose(twin.state()[first.global_id].pose[:2, 3], (10.3, 8.1))
    new = [s for s in twin.state().values() if s.status is ElementStatus.NEW]
    assert len(new) == 2
    assert all(np.array_equal(s.mesh[0], family_mesh("Steel_Drum_55gal")[0]) for s in new)
    assert twin.state()[cone_id(site_model)].mesh is None  # the BIM has the mesh of its own elements


def cone_id(model):
    return _element(model, "Traffic_Cone_Orange_70cm").global_id


def test_without_a_family_mesh_a_new_object_stands_in_as_a_half_metre_box(twin_url, site_model):
    with DigitalTwin.open(twin_url, site_model) as twin:
        new = twin.record(Observation("Rebar_Bundle", None, yaw_pose(6.0, 9.0, 0.0, 0.0), 0.01, 0.9, 50), T0)
        vertices, faces = twin.state()[new.global_id].mesh
    assert np.allclose(vertices.min(axis=0), (-0.25, -0.25, 0.0))
    assert np.allclose(vertices.max(axis=0), (0.25, 0.25, 0.5))
    assert len(faces) == 12


def test_a_place_seen_empty_is_missing(twin, site_model):
    tripod = _element(site_model, "Survey_Tripod_Aluminium")
    state = twin.mark_missing(tripod.global_id, T0, station=2, frames=(4,), robot="spot-2")
    assert state.status is ElementStatus.MISSING and state.pose is None and state.deviation is None
    assert (state.evidence.station, state.robot) == (2, "spot-2")


# ---- history --------------------------------------------------------------------------------------------------

def test_history_holds_observations_and_status_changes_oldest_first(twin, site_model):
    cone = _element(site_model, "Traffic_Cone_Orange_70cm")
    twin.record(_seen(cone), T0)
    twin.record(_seen(cone, _moved(cone, dx=0.01)), T0 + 10)  # still as planned: no status event
    twin.record(_seen(cone, _moved(cone, dx=0.30)), T0 + 20)
    twin.mark_missing(cone.global_id, T0 + 30)
    history = twin.history(cone.global_id)
    assert [(e.kind, e.time) for e in history] == [(OBSERVATION, T0), (STATUS, T0), (OBSERVATION, T0 + 10),
                                                   (OBSERVATION, T0 + 20), (STATUS, T0 + 20), (MISSING, T0 + 30),
                                                   (STATUS, T0 + 30)]
    changes = [(e.data["from"], e.data["to"]) for e in history if e.kind == STATUS]
    assert changes == [("not observed", "as planned"), ("as planned", "deviating"), ("deviating", "missing")]
    assert all(e.source == "spot-1" for e in history)


def test_an_observation_older_than_the_newest_is_kept_as_evidence_but_changes_nothing_now(twin, site_model):
    cone = _element(site_model, "Traffic_Cone_Orange_70cm")
    twin.record(_seen(cone), T0 + 100)
    late = twin.record(_seen(cone, _moved(cone, dx=0.5)), T0)  # uploaded late: it happened earlier
    assert late.status is ElementStatus.AS_PLANNED
    assert [e.kind for e in twin.history(cone.global_id)] == [OBSERVATION, OBSERVATION, STATUS]
    assert twin.state(at=T0 + 50)[cone.global_id].status is ElementStatus.DEVIATING


def test_history_of_an_unknown_global_id_is_a_one_line_error(twin):
    with pytest.raises(TwinError, match="no element with GlobalId 0000000000000000000000"):
        twin.history("0000000000000000000000")


def test_the_state_at_a_past_time_is_rebuilt_by_replay(twin, site_model):
    cone = _element(site_model, "Traffic_Cone_Orange_70cm")
    pallet = _element(site_model, "Pallet_Wood_EUR")
    twin.record(_seen(cone), T0)
    twin.record(_seen(pallet, _moved(pallet, dx=0.4)), T0 + 10)
    twin.record(_seen(cone, _moved(cone, dy=0.2)), T0 + 20)
    assert twin.state(at=T0 - 1)[cone.global_id].status is ElementStatus.NOT_OBSERVED
    at_5 = twin.state(at=T0 + 5)
    assert (at_5[cone.global_id].status, at_5[pallet.global_id].status) == (ElementStatus.AS_PLANNED,
                                                                           ElementStatus.NOT_OBSERVED)
    at_15 = twin.state(at=T0 + 15)
    assert (at_15[cone.global_id].status, at_15[pallet.global_id].status) == (ElementStatus.AS_PLANNED,
                                                                             ElementStatus.DEVIATING)
    assert twin.state(at=T0 + 20)[cone.global_id].status is ElementStatus.DEVIATING


def test_replay_equals_the_live_state_after_a_random_day(twin, twin_url, site_model):
    """Out-of-order times, new objects, missing ones, several robots: the live twin, a replay up to the last
    time and a freshly opened twin agree element by element."""
    rng = np.random.default_rng(7)
    objects = [el for el in site_model.elements if el.ifc_class in ("IfcBuildingElementProxy", "IfcColumn")]
    for step in range(60):
        when = T0 + float(rng.uniform(0, 600))
        robot = f"spot-{rng.integers(1, 4)}"
        if rng.random() < 0.15:
            twin.record(Observation("Steel_Drum_55gal", None, yaw_pose(*rng.uniform(6, 12, 2), 0.0, 0.0), 0.01,
                                    0.9, 80), when, robot=robot)
        elif rng.random() < 0.1:
            twin.mark_missing(objects[rng.integers(len(objects))].global_id, when, robot=robot)
        else:
            el = objects[rng.integers(len(objects))]
            pose = _moved(el, *rng.normal(0, 0.05, 2), yaw_deg=float(rng.normal(0, 4)))
            twin.record(_seen(el, pose, fitness=float(rng.uniform(0.3, 1.0))), when, robot=robot)
    live = twin.state()
    assert live == twin.state(at=T0 + 600)
    with DigitalTwin.open(twin_url, site_model, symmetry=SYMMETRY) as reopened:
        assert reopened.state() == live
    assert len({s.status for s in live.values()}) >= 5  # the day exercised most statuses


# ---- safety events --------------------------------------------------------------------------------------------

def test_safety_events_join_the_history_of_their_work_zone(twin, site_model):
    zone = next(z for z in site_model.zones if z.name == ZONES[0][0])
    sink = TwinSink(twin)
    sink.emit(Event("hav.activity_started", T0, "worker-a1", "dev-1", {"zone": zone.name, "tool": "grinder"}))
    sink.emit(Event("hav.eav_reached", T0 + 60, "worker-a1", "dev-1", {"zone": zone.name, "day_a8": 2.5}))
    sink.emit(Event("hav.gap", T0 + 70, "worker-b2", "dev-2", {}))
    history = twin.history(zone.global_id)
    assert [(e.kind, e.data["kind"]) for e in history] == [(SAFETY, "hav.activity_started"),
                                                          (SAFETY, "hav.eav_reached")]
    assert history[1].data["data"]["day_a8"] == 2.5 and history[1].source == "dev-1"
    assert [e.data["kind"] for e in twin.events(kinds=[SAFETY])] == ["hav.activity_started", "hav.eav_reached",
                                                                     "hav.gap"]


def test_a_group_of_safety_events_is_one_transaction_recorded_whole_or_not_at_all(twin, site_model, monkeypatch):
    zone = next(z for z in site_model.zones if z.name == ZONES[0][0])
    group = safety_group(zone.name)
    with pytest.raises(TwinError, match="finite"):
        TwinSink(twin).emit_many([*group, Event("hav.eav_reached", math.nan, "worker-a1", "dev-1", {})])
    assert twin.events(kinds=[SAFETY]) == []  # none of the group, not even the good events before the bad one
    writes, writing = [], twin.store.writing
    monkeypatch.setattr(twin.store, "writing", lambda: writes.append(1) or writing())
    TwinSink(twin).emit_many(group)
    stored = twin.events(kinds=[SAFETY])
    assert len(writes) == 1 and [e.data["kind"] for e in stored] == [e.kind for e in group]
    assert [e.seq for e in stored] == [stored[0].seq + k for k in range(len(group))]
    assert [e.data["kind"] for e in twin.history(zone.global_id)] == ["hav.activity_started", "hav.eav_predicted"]


def test_a_group_is_in_the_history_once_the_sink_returns_even_if_the_process_dies_then(site_ifc, site_model,
                                                                                        tmp_path):
    import subprocess
    import sys

    url, zone = f"sqlite:///{tmp_path / 'twin.db'}", ZONES[0][0]
    code = ("import sys; sys.path[:0] = sys.argv[1:2]; from twin_workers import record_group_and_die; "
            "record_group_and_die(*sys.argv[2:])")
    died = subprocess.run([sys.executable, "-c", code, str(Path(__file__).parent), url, str(site_ifc),
                           str(tmp_path / "cache"), zone], capture_output=True, text=True, timeout=240)
    assert died.returncode == -signal.SIGKILL and died.stdout == "recorded\n", died.stderr
    with DigitalTwin.open(url, site_model) as reopened:
        assert [e.data["kind"] for e in reopened.events(kinds=[SAFETY])] == [e.kind for e in safety_group(zone)]


def test_events_serve_a_poller_by_seq_and_a_reader_by_time(twin, site_model):
    cone = _element(site_model, "Traffic_Cone_Orange_70cm")
    twin.record(_seen(cone), T0)
    seen = twin.events()
    twin.record(_seen(cone, _moved(cone, dx=0.2)), T0 + 30)
    fresh = twin.events(after=seen[-1].seq)
    assert [e.kind for e in fresh] == [OBSERVATION, STATUS] and all(e.seq > seen[-1].seq for e in fresh)
    assert [e.time for e in twin.events(since=T0)] == [T0 + 30, T0 + 30]


# ---- bad input ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("order", [0, 2.5, -1, float("nan")])
def test_a_symmetry_order_that_is_not_whole_is_refused_at_open(twin_url, site_model, order):
    with pytest.raises(TwinError, match="rotational order about up"):
        DigitalTwin.open(twin_url, site_model, symmetry={"Pallet_Wood_EUR": order})

def _rows(url: str) -> int:
    engine = sa.create_engine(url)
    try:
        with engine.connect() as conn:
            return conn.execute(sa.text("SELECT count(*) FROM twin_events")).scalar_one()
    finally:
        engine.dispose()


def test_an_observation_for_a_global_id_the_model_lacks_is_refused_and_nothing_is_written(twin, twin_url):
    with pytest.raises(TwinError, match=r"site\.ifc has no element with GlobalId 1234567890123456789012$"):
        twin.record(Observation("Pallet_Wood_EUR", "1234567890123456789012", np.eye(4), 0.01, 0.9, 100), T0)
    assert _rows(twin_url) == 0


@pytest.mark.parametrize("pose, time, match", [(np.eye(3), T0, "4x4"), (np.diag([1.0, 1, -1, 1]), T0, "rotation"),
                                               (np.eye(4), float("nan"), "finite"), (np.eye(4), "noon", "finite")])
def test_a_malformed_observation_is_a_one_line_error(twin, twin_url, site_model, pose, time, match):
    cone = _element(site_model, "Traffic_Cone_Orange_70cm")
    with pytest.raises(TwinError, match=match) as caught:
        twin.record(_seen(cone, pose), time)
    assert "\n" not in str(caught.value) and _rows(twin_url) == 0


def test_a_failed_write_leaves_the_history_and_the_state_as_they_were(twin, twin_url, site_model):
    """The status event is refused by the database itself (a trigger): the observation written before it in
    the same transaction is rolled back with it."""
    cone = _element(site_model, "Traffic_Cone_Orange_70cm")
    twin.record(_seen(cone), T0)
    before_rows, before_state = _rows(twin_url), twin.state()
    engine = sa.create_engine(twin_url)
    with engine.begin() as conn:
        for statement in _refuse_status_events(conn.dialect.name):
            conn.exec_driver_sql(statement)
    with pytest.raises(TwinError, match="could not record into the twin at .*the history is unchanged$"):
        twin.record(_seen(cone, _moved(cone, dx=0.5)), T0 + 10)
    assert _rows(twin_url) == before_rows
    assert twin.state() == before_state and twin.history(cone.global_id)[-1].kind == STATUS
    with engine.begin() as conn:
        conn.exec_driver_sql("DROP TRIGGER refuse_status" + (" ON twin_events" if conn.dialect.name == "postgresql"
                                                               else ""))
    engine.dispose()
    assert twin.record(_seen(cone, _moved(cone, dx=0.5)), T0 + 10).status is ElementStatus.DEVIATING
    assert _rows(twin_url) == before_rows + 2


def _refuse_status_events(dialect: str) -> list[str]:
    if dialect == "sqlite":
        return ["CREATE TRIGGER refuse_status BEFORE INSERT ON twin_events WHEN NEW.kind = 'status' "
                "BEGIN SELECT RAISE(ABORT, 'status events refused'); END"]
    return ["CREATE FUNCTION refuse_status() RETURNS trigger AS $$ BEGIN "
            "RAISE EXCEPTION 'status events refused'; END $$ LANGUAGE plpgsql",
            "CREATE TRIGGER refuse_status BEFORE INSERT ON twin_events FOR EACH ROW WHEN (NEW.kind = 'status') "
            "EXECUTE FUNCTION refuse_status()"]


def test_a_twin_url_that_cannot_be_reached_names_it_without_its_password(site_model):
    url = "postgresql+psycopg://robot:s3cret-pw@127.0.0.1:1/twin"
    with pytest.raises(TwinError) as caught:
        DigitalTwin.open(url, site_model)
    message = str(caught.value)
    assert message.startswith("cannot reach the twin at postgresql+psycopg://robot:***@127.0.0.1:1/twin: ")
    assert "s3cret-pw" not in message and "\n" not in message


@pytest.mark.parametrize("url, match", [("mysql://u:pw@host/db", "SQLite or PostgreSQL, not mysql"),
                                        ("not a url", "not a database URL")])
def test_a_url_of_another_kind_is_a_one_line_error(site_model, url, match):
    with pytest.raises(TwinError, match=match) as caught:
        DigitalTwin.open(url, site_model)
    assert "pw" not in str(caught.value)


def test_an_sqlite_path_that_cannot_be_created_is_a_one_line_error(site_model, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    with pytest.raises(TwinError, match="cannot reach the twin at sqlite:///"):
        DigitalTwin.open(f"sqlite:///{blocker / 'twin.db'}", site_model)


def test_the_settings_give_sqlite_in_the_data_folder_unless_a_url_is_set(tmp_path, monkeypatch):
    from bim2rdt.config import get_settings

    monkeypatch.setenv("BIM2RDT_DATA_DIR", str(tmp_path / "var"))
    get_settings.cache_clear()
    settings = get_settings()
    assert settings.twin.resolved_url(settings.data_dir) == f"sqlite:///{tmp_path / 'var' / 'twin.db'}"
    monkeypatch.setenv("BIM2RDT_TWIN__URL", "postgresql+psycopg://robot@db/site")
    get_settings.cache_clear()
    settings = get_settings()
    assert settings.twin.resolved_url(settings.data_dir) == "postgresql+psycopg://robot@db/site"


def test_a_reader_that_opens_a_url_without_a_twin_gets_an_error_and_creates_nothing(twin_url, site_model):
    with pytest.raises(TwinError, match="^no twin at "):
        DigitalTwin.open(twin_url, site_model, create=False)
    with DigitalTwin.open(twin_url, site_model) as created:  # a writer creates it ...
        assert created.events() == []
    with DigitalTwin.open(twin_url, site_model, create=False) as reader:  # ... and then readers find it
        assert reader.state().keys() == {el.global_id for el in site_model.elements}
