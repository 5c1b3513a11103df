"""A settled monitor process: the objects it built before its first message, and its streams as they double, are out
of the collector's passes."""

from __future__ import annotations

import gc

import pytest

from bim2rdt.bus import AccelBatch
from bim2rdt.safety import CallbackSink
from bim2rdt.safety.heap import SETTLE_FROM_STREAMS, HeapSettler, settle, young_passes_after

from hav_helpers import plan_batches


def test_settle_takes_what_exists_out_of_full_collections():
    built = [[object()] for _ in range(50_000)]  # long-lived state, as a monitor's imports and restored streams
    try:
        frozen = settle()
        made_after = [[object()] for _ in range(10)]
        walked = {id(o) for o in gc.get_objects()}  # what the collector's passes (all generations) walk
        assert frozen >= len(built)
        assert not any(id(o) in walked for o in built)
        assert all(id(o) in walked for o in made_after)
    finally:
        gc.unfreeze()
    walked = {id(o) for o in gc.get_objects()}
    assert all(id(o) in walked for o in built[:10])  # unfrozen, walked again


def _walked(*objects) -> bool:
    """Whether the collector's passes still walk every one of ``objects`` (none is frozen)."""
    walked = {id(o) for o in gc.get_objects()}
    return all(id(o) in walked for o in objects)


def test_a_monitor_settles_as_its_streams_double_and_gives_the_heap_back_when_it_closes(make_monitor):
    monitor, _ = make_monitor()
    monitor._heap = HeapSettler(first=1)  # from its first stream on, so a few streams show the doubling
    batch = plan_batches("w0", [("idle", 0.5)])[0]
    streams = monitor._engine.streams
    settled = []
    for k in range(5):  # the 1st, 2nd and 4th stream settle; the 3rd and the 5th do not
        monitor.ingest(AccelBatch(f"w{k}", 0, batch.device_time, batch.fs, batch.xyz))
        settled.append(not _walked(streams[f"w{k}"]))
    assert settled == [True, True, False, True, False]
    assert not _walked(streams["w2"])  # the 4th stream's settle took the 3rd's too
    monitor.close()
    assert _walked(streams["w0"], streams["w3"])  # closing gave the frozen objects back


def test_a_monitor_settles_first_at_a_fleet_not_at_its_first_streams():
    settler, frozen = HeapSettler(), gc.get_freeze_count()
    try:
        assert not settler.grown(SETTLE_FROM_STREAMS - 1) and gc.get_freeze_count() == frozen
        assert settler.grown(SETTLE_FROM_STREAMS) and gc.get_freeze_count() > frozen
        assert not settler.grown(2 * SETTLE_FROM_STREAMS - 1) and settler.grown(2 * SETTLE_FROM_STREAMS)
    finally:
        settler.release()
    assert gc.get_freeze_count() == 0


def test_a_monitor_configured_not_to_settle_leaves_the_collector_alone(make_monitor):
    monitor, _ = make_monitor(settle_heap=False)
    batch = plan_batches("w0", [("idle", 0.5)])[0]
    frozen = gc.get_freeze_count()
    monitor._heap.first = 1  # it would settle at its first stream, were it on
    monitor.ingest(batch)
    assert gc.get_freeze_count() == frozen and _walked(monitor._engine.streams["w0"])


def test_young_passes_wait_for_the_end_of_the_block_and_the_collector_is_on_again_after():
    passes = []

    def note(phase, info):
        if phase == "start":
            passes.append((info["generation"], gc.isenabled()))

    gc.callbacks.append(note)
    try:
        with young_passes_after():
            assert not gc.isenabled()
            made = [[k] for k in range(5 * gc.get_threshold()[0])]  # enough for several young passes
            assert passes == []
        assert gc.isenabled() and passes[:1] == [(0, True)]  # the one pass the block held, at its end
        assert gc.get_count()[0] < gc.get_threshold()[0] and len(made) > 0
        with pytest.raises(RuntimeError), young_passes_after():
            raise RuntimeError("a round that fails")
        assert gc.isenabled()
        gc.disable()  # an application that keeps the collector off: left as it is
        with young_passes_after():
            pass
        assert not gc.isenabled()
    finally:
        gc.enable()
        gc.callbacks.remove(note)


def test_a_monitor_ingests_with_the_collector_held_and_on_again_after(make_monitor):
    monitor, _ = make_monitor()
    seen = []
    monitor.sinks.append(CallbackSink(lambda event: seen.append(gc.isenabled())))
    monitor.ingest_many(plan_batches("w0", [("hammer_drill", 2.0)]))  # starts an activity: events in the commit
    assert seen and not any(seen) and gc.isenabled()
