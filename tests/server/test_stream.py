"""The live stream over real HTTP: a monitor event reaches it within 1 s, workers' exposure and twin records
follow, and a client that reconnects with Last-Event-ID gets what it missed."""

from __future__ import annotations

import time

import httpx
import numpy as np

from bim2rdt.perception.observation import Observation
from server_helpers import auth, feed, vibration
from sse_client import StreamReader


def test_a_monitor_event_reaches_the_stream_within_a_second(served, monitor):
    url, tokens, _ = served
    with StreamReader(url, tokens["viewer"]) as reader:
        monitor.start_session("dev-2", "ben.kraus", "breaker", zone="Work zone A")
        batches = vibration("dev-2", 2.0, 12.0, time.time() - 5)
        feed(monitor, batches)
        produced = time.time()  # the monitor emits to its sinks inside ingest, after the commit
        received, message = reader.wait_for(lambda m: m["kind"] == "safety"
                                            and m["data"]["kind"] == "hav.activity_started"
                                            and m["data"]["source"] == "dev-2")
    assert received - produced < 1.0
    assert received - message["sent"] < 1.0
    assert message["data"]["subject"] == monitor.queries.session("dev-2").subject


def test_exposure_and_twin_records_follow_on_the_stream(served, monitor, twin, site_model):
    url, tokens, _ = served
    with StreamReader(url, tokens["viewer"]) as reader:
        _, first = reader.wait_for(lambda m: m["kind"] == "workers")
        feed(monitor, vibration("dev-1", 5.0, 6.0, time.time() - 30, seq0=40))
        _, later = reader.wait_for(lambda m: m["kind"] == "workers" and m["id"] > first["id"])
        assert later["data"][0]["a8"] > first["data"][0]["a8"]
        crate = next(el for el in site_model.elements if el.ifc_class == "IfcBuildingElementProxy"
                     and el.global_id not in twin.ids.values())
        pose = crate.placement.copy()
        pose[1, 3] += 0.5
        twin.record(Observation(crate.family, crate.global_id, pose, 0.004, 0.9, 150), time.time())
        _, change = reader.wait_for(lambda m: m["kind"] == "element"
                                    and m["data"]["record"]["global_id"] == crate.global_id)
    assert change["data"]["state"]["status"] == "deviating"
    assert np.isclose(change["data"]["state"]["deviation"]["translation"], 0.5)


def test_a_client_that_reconnects_with_last_event_id_gets_what_it_missed(served):
    url, tokens, app = served
    hub = app.state.hub
    marks = [hub.publish("test", {"n": n}).id for n in range(5)]
    headers = {**auth(tokens["viewer"]), "Last-Event-ID": str(marks[1])}
    seen = []
    with httpx.Client(timeout=10) as client, client.stream("GET", f"{url}/api/stream", headers=headers) as response:
        for line in response.iter_lines():
            if line.startswith("id: "):
                seen.append(int(line[4:]))
            if seen and seen[-1] == marks[-1]:
                break
    assert seen[:3] == marks[2:]
