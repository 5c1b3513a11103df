"""Text that enters the twin (family, robot, detector, reason, GlobalId, a safety event's source) is checked where
it enters, with the same limits on SQLite and PostgreSQL; a store written before the checks, holding a lone
surrogate, still serves its state and its exports. Also the numbers of an observation's evidence and the twin's
time and seq arguments: one-line errors, never a traceback."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest
import sqlalchemy as sa

from bim2rdt.bus import Event
from bim2rdt.perception.observation import Observation
from bim2rdt.twin import DigitalTwin, ElementStatus, TwinError

from twin_helpers import T0, family_mesh

SURROGATE = "\ud800"


@pytest.fixture
def twin(twin_url, site_model):
    with DigitalTwin.open(twin_url, site_model, family_mesh=family_mesh) as twin:
        yield twin


def _cone(model):
    return next(el for el in model.elements if el.family == "Traffic_Cone_Orange_70cm")


def _seen(element, **fields) -> Observation:
    values = {"family": element.family, "global_id": element.global_id, "pose": element.placement, "rmse": 0.004,
              "fitness": 0.9, "points": 200, **fields}
    return Observation(**values)


def _rows(url: str) -> int:
    engine = sa.create_engine(url)
    try:
        with engine.connect() as conn:
            return conn.execute(sa.text("SELECT count(*) FROM twin_events")).scalar_one()
    finally:
        engine.dispose()


@pytest.mark.parametrize("field, value, words", [
    ("family", SURROGATE, "family"), ("family", "", "family"), ("family", "a" * 256, "at most 255"),
    ("family", "cone\x00", "control"), ("detector", SURROGATE, "detector"), ("robot", SURROGATE, "robot"),
    ("robot", "r" * 129, "at most 128"), ("robot", "spot\n1", "control"), ("reason", SURROGATE, "reason"),
    ("reason", "x" * 1001, "at most 1000"), ("family", None, "family"), ("family_new", SURROGATE, "family")])
def test_text_that_the_store_cannot_hold_alike_everywhere_is_refused_where_it_enters(twin, twin_url, site_model,
                                                                                     field, value, words):
    cone = _cone(site_model)
    robot = None
    if field == "robot":
        observation, robot = _seen(cone), value
    elif field == "family_new":
        observation = Observation(value, None, np.eye(4), 0.004, 0.9, 200)
    elif field == "reason":
        observation = _seen(cone)
        observation.reason = value
    else:
        observation = _seen(cone, **{field: value})
    with pytest.raises(TwinError, match=words) as caught:
        twin.record(observation, T0, robot=robot)
    assert "\n" not in str(caught.value) and SURROGATE not in str(caught.value)
    assert _rows(twin_url) == 0


def test_the_longest_names_allowed_are_stored_alike_on_both_backends(twin, site_model):
    cone = _cone(site_model)
    state = twin.record(_seen(cone, detector="d" * 64), T0, robot="r" * 128)
    assert state.robot == "r" * 128 and twin.history(cone.global_id)[0].source == "r" * 128


def test_a_safety_event_with_a_source_the_store_cannot_hold_is_refused(twin, twin_url):
    for source in (SURROGATE, "s" * 129):
        with pytest.raises(TwinError, match="source"):
            twin.record_event(Event("hav.eav_predicted", T0, "w-1", source=source, data={"zone": "nowhere"}))
    assert _rows(twin_url) == 0


def _write_old_row(url: str, global_id: str, data: dict, source: str = "spot-1") -> None:
    """An observation as the twin wrote it before text was checked (json.dumps escapes the surrogate)."""
    engine = sa.create_engine(url)
    try:
        with engine.begin() as conn:
            conn.execute(sa.text("INSERT INTO twin_events (kind, time, global_id, source, data, recorded) "
                                 "VALUES ('observation', :t, :g, :s, :d, :r)"),
                         {"t": T0, "g": global_id, "s": source, "d": json.dumps(data), "r": time.time()})
    finally:
        engine.dispose()


def old_store_observation() -> dict:
    pose = np.eye(4)
    pose[:3, 3] = (12.0, 9.0, 0.0)
    return {"family": SURROGATE + "drum", "status": "new", "pose": pose.tolist(), "reason": "x" + SURROGATE,
            "deviation": None, "tolerance": None, "evidence": {"station": 1, "frames": [1], "camera": None,
                                                              "bbox": None},
            "fit": {"rmse": 0.01, "fitness": 0.9, "points": 100, "score": 1.0, "detector": "geo" + SURROGATE}}


def any_family_mesh(family: str):
    """The simulator's mesh of a family, None (a stand-in box) for one it does not know."""
    from bim2rdt.sim.meshes import UnknownFamilyError

    try:
        return family_mesh(family)
    except UnknownFamilyError:
        return None


def test_an_old_store_holding_a_lone_surrogate_still_serves_its_state_and_exports(twin_url, site_model, tmp_path):
    with DigitalTwin.open(twin_url, site_model, family_mesh=any_family_mesh):
        pass
    _write_old_row(twin_url, "0" * 22, old_store_observation())
    with DigitalTwin.open(twin_url, site_model, family_mesh=any_family_mesh) as twin:
        new = twin.state()["0" * 22]
        assert new.status is ElementStatus.NEW and new.family == "\ufffddrum"
        assert twin.events()[0].data["reason"] == "x\ufffd"
        json.loads(twin.export_json(tmp_path / "twin.json").read_text())
        assert twin.export_bcf(tmp_path / "twin.bcf").stat().st_size > 0
        assert twin.export_ifc(tmp_path / "twin.ifc").stat().st_size > 0


@pytest.mark.parametrize("bbox", [(float("nan"), 0, 10, 10), (0, 0, float("inf"), 10), (0, 0, 10), ("a", 0, 1, 1)])
def test_an_observation_whose_box_is_not_four_finite_pixels_is_a_one_line_error(twin, twin_url, site_model, bbox):
    with pytest.raises(TwinError, match="bbox") as caught:
        twin.record(_seen(_cone(site_model), bbox=bbox), T0)
    assert "\n" not in str(caught.value) and _rows(twin_url) == 0


@pytest.mark.parametrize("station, frames", [(float("nan"), ()), (1, (float("nan"),)), ("one", ())])
def test_an_observation_whose_station_or_frames_are_not_whole_numbers_is_a_one_line_error(twin, site_model,
                                                                                         station, frames):
    with pytest.raises(TwinError, match="station|frames"):
        twin.record(_seen(_cone(site_model), station=station, frames=frames), T0)


def test_a_numpy_time_is_a_time(twin, site_model):
    cone = _cone(site_model)
    twin.record(_seen(cone), np.float32(T0))
    twin.mark_missing(cone.global_id, np.float64(T0 + 60))
    assert twin.state(at=np.int64(int(T0) + 10))[cone.global_id].status is ElementStatus.AS_PLANNED


def test_a_seq_beyond_any_store_has_nothing_after_it(twin, site_model):
    twin.record(_seen(_cone(site_model)), T0)
    assert twin.events(after=2**70) == [] and len(twin.events(after=-5)) == 2
    with pytest.raises(TwinError, match="after"):
        twin.events(after=1.5)
