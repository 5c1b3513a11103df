"""A write-locked twin never stalls the HAV monitor: its accounting goes on, the dashboard answers, and every safety
event reaches the twin, in order, once, after the lock (the monitor's durable outbox)."""

from __future__ import annotations

import sqlite3
import threading
import time

import httpx
import pytest

from bim2rdt.bus import LocalBus, encode_accel
from bim2rdt.bus.topics import accel_topic

from server_helpers import SITE_SECRET, auth, config_with_tokens, family_mesh, today_since, vibration

SITE = "test"


def _batches(start: float):
    """Two grinder activities (6 m/s^2) with a quiet pause between and after them: 48 batches of 0.5 s."""
    return (vibration("dev-1", 8.0, 6.0, start) + vibration("dev-1", 4.0, 0.1, start + 8.0, seq0=16)
            + vibration("dev-1", 8.0, 6.0, start + 12.0, seq0=24) + vibration("dev-1", 4.0, 0.1, start + 20.0, seq0=40))


def _monitor(folder):
    from bim2rdt.safety import HavMonitor, MonitorConfig

    config = MonitorConfig(site=SITE, predict_every_s=1.0, commit_delay_s=0.0, outbox_retry_s=0.1)
    monitor = HavMonitor(folder, SITE_SECRET, [], config)
    subject = monitor.start_session("dev-1", "anna.berg", "grinder", zone="Work zone A")
    bus = LocalBus().connect()
    monitor.attach(bus)
    return monitor, subject, bus


def _publish(bus, batches) -> None:
    for batch in batches:
        bus.publish(accel_topic(SITE, "dev-1"), encode_accel(batch), qos=1)


def _day_a8(monitor, subject: str) -> float:
    days = monitor.queries.days_of(subject)
    return monitor.queries.day(subject, days[-1]).a8


@pytest.mark.parametrize("busy_timeout_s, lock_s", [(None, 3.0), (0.2, 2.0)],
                         ids=["the twin waits out the lock", "the twin gives up and is retried"])
def test_a_write_locked_twin_stalls_nothing_and_gets_every_event_after_the_lock(tmp_path, site_model, monkeypatch,
                                                                                busy_timeout_s, lock_s):
    from bim2rdt.server import create_app
    from bim2rdt.server.runner import ServerThread
    from bim2rdt.twin import SAFETY, DigitalTwin

    batches = _batches(today_since(120, 40))
    control, control_subject, control_bus = _monitor(tmp_path / "control")
    _publish(control_bus, batches)
    expected_a8, expected = _day_a8(control, control_subject), [(e.kind, e.time) for e in control.queries.reads.events()]
    control.close()

    if busy_timeout_s is not None:  # the twin's SQLite writer gives up after this (its default waits 60 s)
        monkeypatch.setattr("bim2rdt.twin.store.SQLITE_BUSY_TIMEOUT_S", busy_timeout_s)
    twin = DigitalTwin.open(f"sqlite:///{tmp_path / 'twin.db'}", site_model, family_mesh=family_mesh)
    monitor, subject, bus = _monitor(tmp_path / "hav")
    config, tokens = config_with_tokens(tmp_path)
    app = create_app(twin, monitor, config=config, record_safety=True)
    with ServerThread(app) as server, httpx.Client(base_url=server.url, timeout=30) as http:
        _publish(bus, batches[:12])
        lock = sqlite3.connect(tmp_path / "twin.db", isolation_level=None)
        lock.execute("BEGIN IMMEDIATE")  # another process holds the twin's write lock
        locked_at = time.monotonic()
        feeder = threading.Thread(target=_publish, args=(bus, batches[12:40]))
        feeder.start()
        time.sleep(0.3)
        asked = time.monotonic()
        workers = http.get("/api/workers", headers=auth(tokens["viewer"]))
        answered_s = time.monotonic() - asked
        feeder.join(timeout=lock_s)
        fed_while_locked = not feeder.is_alive()
        time.sleep(max(0.0, lock_s - (time.monotonic() - locked_at)))
        waiting_in_lock = monitor.queries.outbox_status()["twin"]["pending"]
        lock.execute("ROLLBACK")
        lock.close()
        feeder.join()
        _publish(bus, batches[40:])
        assert monitor.drain_outbox(20.0)
        outbox = monitor.queries.outbox_status()["twin"]
    recorded = [e.data for e in twin.events(kinds=[SAFETY])]
    got_a8 = _day_a8(monitor, subject)
    refused, stats = monitor.queries.malformed_messages(), dict(monitor.queries.stats)
    monitor.close()
    twin.close()

    assert workers.status_code == 200 and answered_s < 1.0, answered_s  # before: it waited for the twin
    assert fed_while_locked  # the monitor's ingest never waited on the twin
    assert waiting_in_lock > 0  # the events of the locked stretch waited in the outbox
    assert refused == {} and stats.get("malformed", 0) == 0  # a sink failure is never a refused message
    assert got_a8 == pytest.approx(expected_a8, rel=1e-12)
    assert [(d["kind"], d["time"]) for d in recorded] == expected  # every event, in order, none doubled
    assert [d["data"]["outbox_id"] for d in recorded] == sorted({d["data"]["outbox_id"] for d in recorded})
    if busy_timeout_s is not None:
        assert outbox["failures"] >= 3  # the lock outlasted the retry several times
