"""The exposure store's I/O: a commit costs the same at the end of a shift as at its start."""

from __future__ import annotations

import numpy as np

from bim2rdt.bus import AccelBatch

from hav_helpers import T0


def _vm_steps_per_commit(monitor, batches, clock) -> float:
    """SQLite virtual-machine steps (in units of 100) per single-batch ingest: the work the store does."""
    steps = [0]
    monitor.store._db.set_progress_handler(lambda: steps.__setitem__(0, steps[0] + 1) or 0, 100)
    for batch in batches:
        clock.now = batch.device_time + 0.6
        monitor.ingest_many([batch])
    monitor.store._db.set_progress_handler(None, 100)
    return steps[0] / len(batches)


def test_a_commit_late_in_the_shift_costs_what_an_early_one_did(make_monitor, clock):
    monitor, _ = make_monitor()  # raw batches kept for the default retention (a week)
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
    sizes = dict(store._db.execute("SELECT device, length(samples) FROM raw").fetchall())
    assert sizes == {"w1": 2500 * 3 * 2, "w2": 2500 * 3 * 4}
    back = store.raw_batches("w1", 0)[0]
    assert back.xyz.dtype == np.float32 and np.array_equal(back.xyz, sent.xyz) and back.scale == sent.scale
    assert np.array_equal(store.raw_batches("w2", 0)[0].xyz, xyz)
    store.close()
