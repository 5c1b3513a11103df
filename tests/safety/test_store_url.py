"""The exposure store at a URL (SQLite file or PostgreSQL): a restart resumes, a batch is applied at most once
however many monitors share the store, and older stores are migrated by versioned steps."""

from __future__ import annotations

import sqlite3

import pytest

from bim2rdt.safety import HavMonitor, ListSink, MonitorConfig

from hav_helpers import DAY, T0, Clock, feed, plan_batches

PLAN = [("idle", 2), ("hammer_drill", 20), ("idle", 4)]


def _monitor(folder, url: str | None, clock: Clock, sink: ListSink | None = None) -> HavMonitor:
    return HavMonitor(folder, "test-secret", [sink] if sink else [], MonitorConfig(store_url=url), clock)


def _reference_energy(items, clock: Clock) -> float:
    reference = HavMonitor(None, "test-secret", [], MonitorConfig(), clock)
    subject = reference.start_session("dev-1", "ana", "hammer_drill")
    feed(reference, items, clock)
    energy = reference.queries.day(subject, DAY).energy
    reference.close()
    return energy


def test_a_monitor_on_a_store_url_resumes_where_it_stopped(store_url, tmp_path):
    items = plan_batches("dev-1", PLAN)
    reference = _reference_energy(items, Clock())
    clock = Clock()
    first = _monitor(tmp_path / "first", store_url, clock)
    subject = first.start_session("dev-1", "ana", "hammer_drill")
    feed(first, items[:25], clock)
    first.close()
    second = _monitor(tmp_path / "second", store_url, clock)  # another host: only the URL is shared
    assert second.queries.stream_status("dev-1")["next_seq"] == 25
    feed(second, items[25:], clock)
    assert second.queries.day(subject, DAY).energy == pytest.approx(reference, rel=1e-9)
    assert second.store.applied_count() == len(items)
    second.close()


def test_a_batch_is_applied_at_most_once_when_two_monitors_share_a_store(store_url, tmp_path):
    """A redelivery to a monitor whose memory is behind the store (another process applied the batches) neither
    doubles nor loses exposure: the ledger (device, boot, seq) refuses the commit, the monitor reloads and goes on."""
    items = plan_batches("dev-1", PLAN)
    reference = _reference_energy(items, Clock())
    clock = Clock()
    first = _monitor(tmp_path / "a", store_url, clock)
    subject = first.start_session("dev-1", "ana", "hammer_drill")
    stale = _monitor(tmp_path / "b", store_url, clock)  # restored now: it knows the session, no batch yet
    feed(first, items[:30], clock)  # the first process applies 0..29, then stalls
    feed(stale, items[20:], clock)  # 20..29 redelivered to the second, with the rest
    assert stale.queries.stream_status("dev-1")["duplicates"] == 10
    assert stale.queries.day(subject, DAY).energy == pytest.approx(reference, rel=1e-9)
    first.close()
    stale.close()
    again = _monitor(tmp_path / "c", store_url, clock)
    assert again.queries.day(subject, DAY).energy == pytest.approx(reference, rel=1e-9)
    assert again.store.applied_count() == len(items)
    again.close()


def test_the_old_expiry_index_is_dropped_by_a_versioned_migration_step(tmp_path):
    from bim2rdt.safety.store import SCHEMA_VERSION, ExposureStore

    path = tmp_path / "hav.sqlite"
    old = sqlite3.connect(path)  # a store of an earlier release: no scale column, the old expiry index
    old.execute("CREATE TABLE raw (device TEXT, seq INTEGER, device_time REAL, received_time REAL, fs REAL, "
                "full_scale REAL, n INTEGER, samples BLOB, PRIMARY KEY (device, seq))")
    old.execute("CREATE INDEX raw_received ON raw (received_time)")
    old.execute("INSERT INTO raw VALUES ('w1', 0, 1.7e9, 1.7e9, 5000.0, 2000.0, 1, zeroblob(12))")
    old.commit()
    old.close()
    ExposureStore(path).close()
    db = sqlite3.connect(path)
    indexes = {row[0] for row in db.execute("SELECT name FROM sqlite_master WHERE type = 'index'")}
    columns = {row[1] for row in db.execute("PRAGMA table_info(raw)")}
    version = db.execute("SELECT version FROM hav_schema").fetchall()
    db.close()
    assert "raw_received" not in indexes and {"raw_expiry", "raw_window"} <= indexes
    assert {"scale", "codec", "kept"} <= columns
    assert version == [(SCHEMA_VERSION,)]
    store = ExposureStore(path)  # opened again: nothing left to run, the old row still reads
    assert store.raw_batches("w1", 0)[0].xyz.shape == (1, 3)
    store.close()


def test_a_bad_store_url_is_one_line():
    from bim2rdt.safety.errors import StoreError

    with pytest.raises(StoreError, match="the exposure store is stored in SQLite or PostgreSQL, not mysql"):
        HavMonitor(None, "s", [], MonitorConfig(store_url="mysql://u:secret@h/db"))
