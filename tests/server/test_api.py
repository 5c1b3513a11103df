"""The API over real HTTP (uvicorn on a free port): what each endpoint returns for the recorded twin and the fed
monitor."""

from __future__ import annotations

import io
import zipfile

import numpy as np
import pytest

from server_helpers import T_TWIN, auth


def get(client, path, role="viewer", **params):
    response = client.get(path, headers=auth(client.tokens[role]), params=params)
    assert response.status_code == 200, response.text
    return response


def test_health_needs_no_token_and_says_what_is_served(client):
    body = client.get("/api/health").json()
    assert body["status"] == "ok" and body["twin"] and body["monitor"]


def test_elements_carry_status_deviation_and_colour(client, twin):
    elements = {e["global_id"]: e for e in get(client, "/api/elements").json()}
    ids = twin.ids
    assert elements[ids["planned"]]["status"] == "as planned"
    moved = elements[ids["moved"]]
    assert moved["status"] == "deviating"
    assert moved["deviation"]["translation"] == pytest.approx(0.4, abs=1e-6)
    assert moved["colour"].startswith("#") and moved["colour"] != elements[ids["planned"]]["colour"]
    assert elements[ids["missing"]]["status"] == "missing"
    assert elements[ids["new"]]["status"] == "new" and elements[ids["new"]]["ifc_class"] is None
    walls = [e for e in elements.values() if e["ifc_class"] == "IfcWall"]
    assert walls and all(e["status"] == "not observed" for e in walls)


def test_one_element_has_its_history_oldest_first(client, twin):
    body = get(client, f"/api/elements/{twin.ids['moved']}").json()
    kinds = [record["kind"] for record in body["history"]]
    assert kinds[:2] == ["observation", "status"]
    assert body["history"][1]["data"]["to"] == "deviating"


def test_an_unknown_element_is_404_for_a_reader(client):
    response = client.get("/api/elements/NO_SUCH_GUID_000000000", headers=auth(client.tokens["viewer"]))
    assert response.status_code == 404


def test_the_state_at_a_past_time_is_before_the_later_records(client, twin):
    before = {e["global_id"]: e["status"] for e in get(client, "/api/state", at=T_TWIN + 10).json()["elements"]}
    assert before[twin.ids["planned"]] == "as planned"
    assert before[twin.ids["moved"]] == "not observed"  # recorded at T + 30
    now = get(client, "/api/state").json()
    assert now["counts"]["deviating"] == 1 and now["counts"]["missing"] == 1


def test_observations_page_by_seq(client):
    first = get(client, "/api/observations").json()
    assert [r["kind"] for r in first].count("observation") == 3 and "missing" in [r["kind"] for r in first]
    after = get(client, "/api/observations", after=first[1]["seq"]).json()
    assert [r["seq"] for r in after] == [r["seq"] for r in first[2:]]


def test_the_plan_has_walls_zones_elements_and_the_robot_path(client, twin):
    plan = get(client, "/api/plan").json()
    assert len(plan["structure"]) >= 6  # the site's walls and columns
    assert any(zone["off_limits"] for zone in plan["zones"])
    moved = next(e for e in plan["elements"] if e["global_id"] == twin.ids["moved"])
    found, planned = np.mean(moved["outline"], axis=0), np.mean(moved["planned"], axis=0)
    assert found[0] - planned[0] == pytest.approx(0.4, abs=0.05)
    assert [(p["x"], p["y"]) for p in plan["robot_path"]] == [(1.0, 1.0), (3.0, 1.0), (5.0, 2.0)]
    xmin, ymin, xmax, ymax = plan["bounds"]
    assert xmax - xmin > 15 and ymax - ymin > 10  # the 20 x 14 m site


def test_the_plan_at_a_past_time_has_what_the_robot_had_found_by_then(client, twin):
    plan = get(client, "/api/plan", at=T_TWIN + 10).json()
    statuses = {e["global_id"]: e["status"] for e in plan["elements"]}
    assert statuses[twin.ids["planned"]] == "as planned" and statuses[twin.ids["moved"]] == "not observed"
    assert twin.ids["new"] not in statuses
    assert [(p["x"], p["y"]) for p in plan["robot_path"]] == [(1.0, 1.0)]
    assert get(client, "/api/state").json()["span"] == [T_TWIN, T_TWIN + 90]


def test_the_3d_model_is_binary_gltf_with_a_node_per_element(client, twin):
    data = get(client, "/api/model.glb").content
    assert data[:4] == b"glTF"
    import trimesh

    scene = trimesh.load(io.BytesIO(data), file_type="glb")
    names = set(scene.graph.nodes_geometry)
    assert {twin.ids["moved"], twin.ids["new"]} <= names


def test_bcf_and_ifc_downloads_are_the_twins_exports(client, twin):
    bcf = get(client, "/api/exports/twin.bcf").content
    with zipfile.ZipFile(io.BytesIO(bcf)) as archive:
        markups = [n for n in archive.namelist() if n.endswith("markup.bcf")]
    assert len(markups) == 3  # deviating, missing, new
    ifc = get(client, "/api/exports/twin.ifc").content
    assert ifc.startswith(b"ISO-10303-21") and twin.ids["new"].encode() in ifc


def test_workers_appear_under_pseudonyms_with_exposure_and_live_activity(client):
    workers = get(client, "/api/workers").json()
    assert len(workers) == 1
    worker = workers[0]
    assert worker["subject"].startswith("w-") and "anna" not in str(worker)
    assert 0 < worker["a8"] < 2.5 and worker["risk"] == "below_eav"
    assert worker["active"] and worker["devices"][0]["tool"] == "grinder"
    assert worker["a_hv"] == pytest.approx(6.0, rel=0.1)
    # the rest of the day's energy to the EAV (2.5 m/s^2 A(8) over 8 h) at the running a_hv: about 8 h (2.5/6)^2
    t0 = 8 * 3600.0
    to_eav = (2.5**2 - worker["a8"] ** 2) * t0 / worker["a_hv"] ** 2
    assert worker["seconds_to_eav"] == pytest.approx(to_eav, rel=1e-6)
    assert worker["seconds_to_elv"] == pytest.approx((5.0**2 - worker["a8"] ** 2) * t0 / worker["a_hv"] ** 2, rel=1e-6)
    assert 4000 < to_eav < 6000
    assert get(client, f"/api/workers/{worker['subject']}").json()["days"]


def test_refused_messages_show_per_device_even_from_a_device_that_sends_only_garbage(client, monitor):
    from bim2rdt.bus import accel_topic

    assert get(client, "/api/devices/refused").json() == []
    assert get(client, "/api/workers").json()[0]["devices"][0]["counters"]["malformed"] == 0
    for device, payload in [("dev-1", b"HAV1 garbage"), ("dev-1", b"not even magic"), ("junk-7", b"\x00" * 40)]:
        assert monitor.ingest_payload(accel_topic("test", device), payload) == []
    refused = get(client, "/api/devices/refused").json()
    assert [(r["device"], r["count"]) for r in refused] == [("dev-1", 2), ("junk-7", 1)]
    worker = get(client, "/api/workers").json()[0]
    assert refused[0]["subject"] == worker["subject"] and refused[1]["subject"] is None
    assert "HAV1 magic" in refused[1]["last_reason"] and refused[1]["last_received"] > 0
    assert worker["devices"][0]["counters"]["malformed"] == 2
    assert "junk-7" not in str(get(client, "/api/workers").json())  # garbage is never a worker's exposure


def test_safety_events_are_listed(client):
    events = get(client, "/api/events").json()
    assert "hav.activity_started" in [e["kind"] for e in events]
    assert all(e["subject"].startswith("w-") for e in events)


def test_api_answers_are_never_sniffed_or_cached_even_refusals(client):
    viewer = auth(client.tokens["viewer"])
    answers = [client.get("/api/elements", headers=viewer), client.get("/api/health"),
               client.get("/api/elements"),  # 401
               client.get("/api/elements/NOPE", headers=viewer),  # 404
               client.get("/api/state", params={"at": -1}, headers=viewer),  # 422
               client.request("GET", "/api/workers", content=b"x" * 9000, headers=viewer)]  # 413
    assert [a.status_code for a in answers] == [200, 200, 401, 404, 422, 413]
    for answer in answers:
        assert answer.headers["x-content-type-options"] == "nosniff", answer.request.url
        assert answer.headers["cache-control"] == "no-store", answer.request.url


def test_a_history_written_before_text_was_checked_is_still_served_whole(client, tmp_path):
    """An observation of a family holding a lone surrogate (accepted before the twin checked text) is in the
    store: every read and both exports still answer, the surrogate shown as U+FFFD."""
    import json
    import time

    import sqlalchemy as sa

    data = {"family": "\ud800", "status": "new", "pose": np.eye(4).tolist(), "reason": "\udc00", "deviation": None,
            "tolerance": None, "fit": {"rmse": 0.01, "fitness": 0.9, "points": 100, "score": 1.0, "detector": ""},
            "evidence": {"station": 4, "frames": [4], "camera": None, "bbox": None}}
    engine = sa.create_engine(f"sqlite:///{tmp_path / 'twin.db'}")
    with engine.begin() as conn:
        conn.execute(sa.text("INSERT INTO twin_events (kind, time, global_id, source, data, recorded) VALUES "
                             "('observation', :t, :g, 'spot-1', :d, :r)"),
                     {"t": T_TWIN + 120, "g": "1" * 22, "d": json.dumps(data), "r": time.time()})
    engine.dispose()
    for path in ("/api/elements", "/api/state", "/api/plan", "/api/observations", f"/api/elements/{'1' * 22}",
                 "/api/model.glb", "/api/exports/twin.bcf", "/api/exports/twin.ifc"):
        get(client, path)
    elements = {e["global_id"]: e for e in get(client, "/api/elements").json()}
    assert elements["1" * 22]["family"] == "\ufffd"


@pytest.mark.parametrize("path, params", [("/api/state", {"at": "inf"}), ("/api/state", {"at": "nan"}),
                                          ("/api/plan", {"at": "-inf"}), ("/api/events", {"since": "1e400"})])
def test_a_non_finite_query_number_is_422_without_echoing_it(client, path, params):
    response = client.get(path, params=params, headers=auth(client.tokens["viewer"]))
    assert response.status_code == 422, response.text
    assert not any(word in response.text.lower() for word in ("inf", "nan", "1e400"))


def test_safety_events_are_listed_in_event_time_order_even_when_committed_out_of_it(client, monitor):
    from server_helpers import feed, today_since, vibration

    monitor.start_session("dev-2", "bo.lind", "grinder", zone="Work zone A")
    earlier = today_since(150, 160)  # before dev-1's feed (60 s back), committed after it
    feed(monitor, vibration("dev-2", 10.0, 6.0, earlier))
    monitor.flush()
    events = get(client, "/api/events").json()
    times = [e["time"] for e in events]
    assert min(times) < earlier + 11.0 and len({e["subject"] for e in events}) == 2  # both workers' events
    assert times == sorted(times)
