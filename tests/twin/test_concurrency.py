"""Four robot processes record into one twin at once: nothing is lost, nothing is doubled, the status changes they
log stay one chain per element, the unplanned drum they all see is one new object, and replay equals the state."""

from __future__ import annotations

import multiprocessing
from collections import Counter

import pytest

from bim2rdt.twin import OBSERVATION, STATUS, DigitalTwin, ElementStatus

from twin_workers import NEW_DRUM_XY, record_burst

ROBOTS = 4
STEPS = 40


def test_four_processes_recording_at_once_lose_nothing(twin_url, site_ifc, site_model, tmp_path):
    context = multiprocessing.get_context("spawn")
    barrier = context.Barrier(ROBOTS)
    processes = [context.Process(target=record_burst, args=(twin_url, str(site_ifc), str(tmp_path / "cache"), robot,
                                                            STEPS, barrier)) for robot in range(ROBOTS)]
    for process in processes:
        process.start()
    for process in processes:
        process.join(timeout=240)
    assert [p.exitcode for p in processes] == [0] * ROBOTS

    with DigitalTwin.open(twin_url, site_model) as twin:
        events = twin.events()
        observations = [e for e in events if e.kind == OBSERVATION]
        assert len(observations) == ROBOTS * (STEPS + 1)
        recorded = Counter((e.source, tuple(e.data["evidence"]["frames"])) for e in observations)
        assert set(recorded.values()) == {1}
        assert len(recorded) == ROBOTS * (STEPS + 1)
        assert [e.seq for e in events] == sorted({e.seq for e in events})
        if twin_url.startswith("postgresql"):  # SQLite hands its write lock to whoever retries first: in turns
            switches = sum(a.source != b.source for a, b in zip(observations, observations[1:]))
            assert switches > 2 * ROBOTS  # the robots really wrote at the same time, not one after the other

        state = twin.state()
        new = [s for s in state.values() if s.status is ElementStatus.NEW]
        assert len(new) == 1 and tuple(new[0].pose[:2, 3]) == pytest.approx(NEW_DRUM_XY)

        for global_id in {e.global_id for e in observations}:
            changes = [e.data for e in events if e.kind == STATUS and e.global_id == global_id]
            assert changes[0]["from"] == "not observed"
            assert all(a["to"] == b["from"] for a, b in zip(changes, changes[1:]))
            assert changes[-1]["to"] == state[global_id].status.value
        assert state == twin.state(at=max(e.time for e in events))
