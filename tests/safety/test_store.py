"""The exposure store's I/O: a commit costs the same at the end of a shift as at its start."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.bus import AccelBatch

from hav_helpers import T0


def _vm_steps_per_commit(monitor, batches, clock) -> float:
    """SQLite virtual-machine steps (in units of 100) per single-batch ingest: the work the store does."""
    steps = [0]
    monitor.store._writer.connection.dbapi_connection.set_progress_handler(lambda: steps.__setitem__(0, steps[0] + 1) or 0, 100)
    for batch in batches:
        clock.now = batch.device_time + 0.6
        monitor.ingest_many([batch])
    monitor.store._writer.connection.dbapi_connection.set_progress_handler(None, 100)
    return steps[0] / len(batches)


def test_a_commit_late_in_the_shift_costs_what_an_early_one_did(make_monitor, clock):
    monitor, _ = make_monitor(raw_recent_s=86400.0)  # every raw batch kept (a day of recent samples)
    monitor.start_session("dev-1", "una", "grinder")
    quiet = np.full((500, 3), [0.0, 0.0, 9.81], np.float32)
    batches = [AccelBatch("dev-1", seq, T0 + 0.1 * seq, 5000.0, quiet, 2000.0) for seq in range(1200)]
    early = _vm_steps_per_commit(monitor, batches[:100], clock)
    _vm_steps_per_commit(monitor, batches[100:1100], clock)
    late = _vm_steps_per_commit(monitor, batches[1100:], clock)
    assert monitor.store.raw_count() == 1200  # nothing dropped: the cost is not saved by losing raw data
    assert late < 1.5 * early, (early, late)  # before the fix: a scan of the stream's whole raw history


def test_raw_int16_batches_are_stored_as_counts_and_restored_bit_for_bit(tmp_path):
    from bim2rdt.bus import decode_accel, encode_accel
    from bim2rdt.safety.store import ExposureStore

    xyz = np.random.default_rng(1).normal(0, 80, (2500, 3)).astype(np.float32)
    sent = decode_accel(encode_accel(AccelBatch("w1", 3, T0, 5000.0, xyz, 1961.3))).received_at(T0 + 1)
    floats = AccelBatch("w2", 0, T0, 5000.0, xyz, 1961.3, T0 + 1)  # not counts: kept as float32
    store = ExposureStore(tmp_path / "hav.sqlite")
    with store.transaction():
        store.save_raw([sent, floats])
    sizes = dict(store._writer.exec_driver_sql("SELECT device, length(samples) FROM raw").fetchall())
    assert sizes == {"w1": 2500 * 3 * 2, "w2": 2500 * 3 * 4}
    back = store.raw_batches("w1", 0)[0]
    assert back.xyz.dtype == np.float32 and np.array_equal(back.xyz, sent.xyz) and back.scale == sent.scale
    assert np.array_equal(store.raw_batches("w2", 0)[0].xyz, xyz)
    store.close()


def _plan(db, sql: str, **params) -> list[str]:
    return [row[3] for row in db.execute(f"EXPLAIN QUERY PLAN {sql}", params)]


def test_a_raw_window_is_a_two_sided_range_on_the_device_time_index(tmp_path):
    import sqlite3

    from bim2rdt.safety.store import RAW_WINDOW_SQL, ExposureStore

    path = tmp_path / "hav.sqlite"
    old = sqlite3.connect(path)  # a store made before the index: the raw table, no raw_window index
    old.execute("CREATE TABLE raw (device TEXT, seq INTEGER, device_time REAL, received_time REAL, fs REAL, "
                "full_scale REAL, n INTEGER, samples BLOB, scale REAL, PRIMARY KEY (device, seq))")
    old.close()
    ExposureStore(path).close()  # opening it migrates it
    db = sqlite3.connect(path)
    plan = _plan(db, RAW_WINDOW_SQL, device="w1", start=T0, end=T0 + 10, lookback=61.0)
    db.close()
    # without the index: "SEARCH raw USING INDEX sqlite_autoindex_raw_1 (device=?)", every row of the device
    assert any("USING INDEX raw_window (device=? AND device_time>? AND device_time<?)" in step for step in plan), plan
    assert not any(step.startswith("SCAN raw") for step in plan), plan


def test_a_raw_window_holds_exactly_the_batches_with_samples_in_it(tmp_path):
    from bim2rdt.safety.store import ExposureStore

    one = np.zeros((2500, 3), np.float32)  # 0.5 s at 5 kHz
    longest = np.zeros((300_000, 3), np.float32)  # 60 s: the longest batch the bus and the monitor take
    batches = [AccelBatch("w1", 0, T0 - 100.0, 5000.0, longest, None, T0)]
    batches += [AccelBatch("w1", k, T0 - 40.0 + 0.5 * (k - 1), 5000.0, one, None, T0) for k in range(1, 200)]
    batches += [AccelBatch("w2", 0, T0, 5000.0, one, None, T0)]
    store = ExposureStore(tmp_path / "hav.sqlite")
    with store.transaction():
        store.save_raw(batches)
    expected = [b.seq for b in batches if b.device == "w1" and b.device_time < T0 - 30 and
                b.device_time + b.duration_s > T0 - 41.5]
    assert [b.seq for b in store.raw_window("w1", T0 - 41.5, T0 - 30)] == expected == [0, *range(1, 21)]
    assert [b.seq for b in store.raw_window("w1", T0 - 40.0, T0 - 39.0)] == [1, 2]  # 0 ends at T0 - 40
    assert [b.seq for b in store.raw_window("w1", T0 - 40.1, T0 - 40.05)] == [0]  # 0 began 59.9 s before
    store.close()


def test_the_monitor_refuses_a_batch_longer_than_the_bus_allows(make_monitor):
    from bim2rdt.safety import HavError

    monitor, _ = make_monitor()
    too_long = AccelBatch("dev-1", 0, T0, 100.0, np.zeros((6001, 3), np.float32), 2000.0, T0)  # 60.01 s
    with pytest.raises(HavError, match="60.01 s of samples: at most 60 s"):
        monitor.ingest_many([too_long])
    assert monitor.store.raw_count() == 0


def test_stream_states_are_saved_as_the_json_that_json_dumps_writes_and_read_back_equal(tmp_path):
    import json

    from bim2rdt.safety.store import ExposureStore, _dumps

    states = {"w1": [[3, 5000.0, T0 + 3.0, [[4, 6]], None, 0, [], "böot \"7\"", False, [[1.0, 2.0, 3]]],
                     ["w1@1.000", "2026-12-06", T0, 327.4354438224406, 3.0, 0.0, 0.0, None, 0.0, 0.0, 0.5],
                     0.019999980926513672, {"batches": 3, "gap_s": 1e-300}],
              "w2": [[None, 0.0, None, [], None, 0, [], None, True, []], [None, "", 0.0] + [0.0] * 8, None, {}]}
    assert all(_dumps(state) == json.dumps(state) for state in states.values())
    store = ExposureStore(tmp_path / "hav.sqlite")
    with store.transaction():
        store.save_streams((device, state, bytes([i])) for i, (device, state) in enumerate(states.items()))
    texts = dict(store._writer.exec_driver_sql("SELECT device, state FROM streams").fetchall())
    assert texts == {device: json.dumps(state) for device, state in states.items()}
    assert store.streams() == {device: (state, bytes([i])) for i, (device, state) in enumerate(states.items())}
    store.close()
