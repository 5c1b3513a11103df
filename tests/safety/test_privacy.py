"""Pseudonyms, the identity map kept apart, and raw-data retention."""

from __future__ import annotations

import sqlite3
import stat

import pytest

from bim2rdt.safety import AccessDenied, IdentityMap, pseudonym

from hav_helpers import T0, feed, plan_batches


def test_a_pseudonym_is_stable_per_site_and_different_across_sites():
    assert pseudonym("alice", "site-a") == pseudonym("alice", "site-a")
    assert pseudonym("alice", "site-a") != pseudonym("alice", "site-b")
    assert "alice" not in pseudonym("alice", "site-a")


def test_only_the_safety_role_reads_the_identity_map(tmp_path):
    path = tmp_path / "private" / "identity.sqlite"
    writer = IdentityMap(path, role="monitor")
    writer.remember("w-123", "alice")
    with pytest.raises(AccessDenied):
        writer.real_name("w-123")
    assert IdentityMap(path, role="safety").real_name("w-123") == "alice"
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert stat.S_IMODE(path.parent.stat().st_mode) == 0o700


def test_the_exposure_store_holds_pseudonyms_only(make_monitor, clock, tmp_path):
    monitor, sink = make_monitor()
    subject = monitor.start_session("dev-1", "Alice Smith", "grinder")
    feed(monitor, plan_batches("dev-1", [("idle", 2), ("grinder", 10)]), clock)
    monitor.close()
    raw = b"".join(path.read_bytes() for path in (tmp_path / "data").glob("hav.sqlite*"))
    assert b"Alice" not in raw
    assert subject.encode() in raw
    assert all(e.subject == subject for e in sink.events)
    assert IdentityMap(tmp_path / "data" / "private" / "identity.sqlite", "safety").real_name(subject) == "Alice Smith"


def test_the_store_runs_in_wal_mode(make_monitor, tmp_path):
    make_monitor()
    mode = sqlite3.connect(tmp_path / "data" / "hav.sqlite").execute("PRAGMA journal_mode").fetchone()[0]
    assert mode == "wal"


def test_raw_batches_are_kept_for_the_retention_only(make_monitor, clock):
    monitor, _ = make_monitor(raw_retention_s=60.0)
    monitor.start_session("dev-1", "lee", "grinder")
    items = plan_batches("dev-1", [("grinder", 30)])
    feed(monitor, items[:30], clock)
    assert monitor.store.raw_count() == 30
    clock.now = T0 + 200.0  # later: the first batches are past retention
    monitor.ingest_many(items[30:])
    assert monitor.store.raw_seqs("dev-1") == list(range(30, 60))  # the old ones are gone, the new ones kept


def test_with_zero_retention_only_unframed_samples_are_kept(make_monitor, clock):
    monitor, _ = make_monitor(raw_retention_s=0.0)
    monitor.start_session("dev-1", "max", "grinder")
    feed(monitor, plan_batches("dev-1", [("grinder", 20)]), clock)
    assert monitor.store.raw_count() <= 2  # a frame is 0.82 s: at most two 0.5 s batches still needed
