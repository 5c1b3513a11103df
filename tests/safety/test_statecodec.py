"""A stream's packed state (safety.statecodec) reads back as exactly what its JSON form reads back as, a state the
packing does not cover is written as that JSON, and a store written as JSON by an older monitor restores."""

from __future__ import annotations

import json
import math
import sqlite3

import numpy as np
import pytest

from bim2rdt.bus import AccelBatch
from bim2rdt.safety.activity import ActivityState
from bim2rdt.safety.statecodec import PACKED_PREFIX, decode_state, encode_state
from bim2rdt.safety.streams import PushResult, StreamBuffer

from hav_helpers import T0


def _buffer(fs=5000.0, boot=None, restart=False, gaps=False) -> StreamBuffer:
    buffer = StreamBuffer()
    for seq in (0, 1, 4, 5) if gaps else (0, 1, 2):
        buffer.push(AccelBatch("w1", seq, T0 + seq * 0.5, fs, np.zeros((int(fs) // 2, 3), np.float32)), T0 + 9.0)
    buffer.expire(T0 + 30.0, PushResult())
    if boot is not None:
        buffer.announce_boot(boot)
        if restart:
            buffer.announce_boot(boot + "-2")
    return buffer


def _json_form(buffer, activity, offset, counters) -> str:
    return json.dumps([buffer.to_list(), activity.to_list(), offset, counters])


STATES = {
    "steady": (_buffer(), ActivityState("w1@1.000", "2026-12-06", T0, 327.4354438224406, 3.0, predicted_at_s=0.5),
               0.019999980926513672, {"batches": 3}),
    "idle, nothing yet": (StreamBuffer(), ActivityState(), None, {}),
    "gaps, boot, a dip, floats everywhere": (
        _buffer(boot="bööt \"7\"", restart=True, gaps=True),
        ActivityState("w1@2.5", "2026-12-07", T0 + 2.5, 1e-300, 0.5, 0.25, 0.5, T0 + 3.0, 1.5, 2.0, None),
        -3.5e9, {"batches": 4, "gaps": 1, "gap_s": 1.0, "rejected_s": 0.1, "untriggered_energy": 5e-324}),
    "inf and nan": (_buffer(), ActivityState("w", "d", math.inf, math.nan, 1.0), -math.inf, {"x": math.nan}),
}


@pytest.mark.parametrize("name", list(STATES))
def test_a_packed_state_reads_back_as_its_json_form_does(name):
    buffer, activity, offset, counters = STATES[name]
    text = encode_state(buffer, activity, offset, counters)
    assert text.startswith(PACKED_PREFIX)
    decoded = decode_state(text)
    expected = json.loads(_json_form(buffer, activity, offset, counters))
    assert json.dumps(decoded) == json.dumps(expected)  # the same values, types and order (NaN compares unequal)
    assert [type(v) for v in decoded[0] + decoded[1]] == [type(v) for v in expected[0] + expected[1]]
    assert {k: type(v) for k, v in decoded[3].items()} == {k: type(v) for k, v in expected[3].items()}


def test_a_buffer_loaded_from_a_packed_state_packs_the_same_again():
    buffer, activity, offset, counters = STATES["gaps, boot, a dip, floats everywhere"]
    text = encode_state(buffer, activity, offset, counters)
    state = decode_state(text)
    again = StreamBuffer()
    again.load(state[0], [])
    assert encode_state(again, ActivityState(*state[1]), state[2], state[3]) == text


@pytest.mark.parametrize("case", ["integer rate", "integer counter beyond 64 bits", "old integer run times",
                                  "a counter of another type"])
def test_what_the_packing_does_not_hold_as_it_is_is_written_as_json(case):
    buffer, activity, counters = _buffer(), ActivityState("w1@1.000", "2026-12-06", T0, 1.0, 1.0), {"batches": 3}
    if case == "integer rate":
        buffer = _buffer(fs=5000)
    elif case == "integer counter beyond 64 bits":
        counters = {"batches": 2**70}
    elif case == "old integer run times":  # a 7-item state of an older monitor: recent times as integers
        buffer = StreamBuffer()
        buffer.load([3, 5000.0, T0 + 1.5, [], T0 + 1.5, 0, [1000, 500]], [])
    else:
        counters = {"batches": True}  # a bool is no int here: JSON keeps it true
    text = encode_state(buffer, activity, 0.02, counters)
    assert text == _json_form(buffer, activity, 0.02, counters)
    assert decode_state(text) == json.loads(text)


def test_a_store_written_as_json_by_an_older_monitor_restores_and_goes_on_packed(make_monitor):
    monitor, _ = make_monitor()
    batch = AccelBatch("w1", 0, T0, 5000.0, np.full((2500, 3), 9.81, np.float32), 2000.0, T0 + 0.6)
    monitor.ingest_many([batch], now=T0 + 0.6)
    path = monitor.store.path
    monitor.close()
    with sqlite3.connect(path) as db:
        (state_text,) = db.execute("SELECT state FROM streams").fetchone()
        assert state_text.startswith(PACKED_PREFIX)
        db.execute("UPDATE streams SET state = ?", (json.dumps(decode_state(state_text)),))  # as an older monitor
    again, _ = make_monitor()
    stream = again._engine.streams["w1"]
    assert stream.buffer.next_seq == 1 and stream.buffer.last_end == T0 + 0.5 and stream.counters["batches"] == 1
    assert again.ingest_many([batch], now=T0 + 1.0) == []  # the restored buffer knows the batch it took
    assert again._engine.streams["w1"].counters["duplicates"] == 1
    again.close()
    with sqlite3.connect(path) as db:
        assert db.execute("SELECT state FROM streams").fetchone()[0].startswith(PACKED_PREFIX)
