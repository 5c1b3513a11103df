"""A stream's saved state as compact text: its numbers packed as binary (base64) instead of written as JSON.

Every ingest saves the state of each stream it touched: the ordering buffer (:mod:`~bim2rdt.safety.streams`),
the running activity (:mod:`~bim2rdt.safety.activity`), the clock offset and the counters. As JSON (``[buffer,
activity, clock offset, counters]``) most of its cost is writing about fifteen floats as shortest decimal text:
building and writing it took about 6.5 us a stream, 2000 streams a round. Packed with :mod:`struct`, each float
is its 8 bytes, exactly, so the same values read back; packing takes about 4 us a stream (decision 0047).

The text is ``"b1:"`` and the base64 of the packed state, so it goes in the same text column on SQLite and
PostgreSQL. :func:`decode_state` reads it, and the JSON text of older rows (and of the rare state the packing does
not cover: a value of an unexpected type, an integer beyond 64 bits), into the same nested list that
``json.loads`` gives for the JSON form; :func:`encode_state` falls back to that JSON form itself.
"""

from __future__ import annotations

import base64
import binascii
import json
import struct
from collections.abc import Callable
from typing import Any

__all__ = ["PACKED_PREFIX", "decode_state", "encode_state"]

PACKED_PREFIX = "b1:"
"""Starts the text of a packed state (JSON text starts with '[')."""
_HEAD = struct.Struct("<Hqdddq10d7H")
"""Presence bits, next seq, rate, segment end, last end, seq offset, the activity's started, energy, seconds, low
energy, low seconds, low since, rejected s, gap s, predicted at, the clock offset; then the counts of skipped
ranges and runs, the byte lengths of the boot, activity id and day, the number of counters, and a spare 0."""
_PAIR, _RUN, _NAME = struct.Struct("<qq"), struct.Struct("<ddq"), struct.Struct("<H")
_INT_VALUE, _FLOAT_VALUE = struct.Struct("<?q"), struct.Struct("<?d")
"""A counter: its name's byte length, its name, then whether it is an integer, and its value (8 bytes)."""
(_NEXT_SEQ, _END_TIME, _LAST_END, _BOOT, _RESTART, _ACTIVITY, _LOW_SINCE, _PREDICTED,
 _OFFSET) = (1 << bit for bit in range(9))
_FLOAT, _INT = float, int


def encode_state(buffer: Any, activity: Any, clock_offset_s: float | None, counters: dict[str, float],
                 fallback: Callable[[Any], str] = json.dumps) -> str:
    """A stream's state as text: packed when every value has the type it should, else ``fallback`` (JSON) of
    ``[buffer.to_list(), activity.to_list(), clock_offset_s, counters]``.

    Args:
        buffer: The stream's :class:`~bim2rdt.safety.streams.StreamBuffer`.
        activity: Its tracker's :class:`~bim2rdt.safety.activity.ActivityState`.
        clock_offset_s: Its clock offset, seconds (None before a batch came).
        counters: Its counters (integer counts and float seconds).
        fallback: Writes the JSON form.

    Returns:
        The text to store.
    """
    try:
        return PACKED_PREFIX + binascii.b2a_base64(_pack(buffer, activity, clock_offset_s, counters),
                                                   newline=False).decode("ascii")
    except (TypeError, struct.error, _Unpackable):
        return fallback([buffer.to_list(), activity.to_list(), clock_offset_s, counters])


def decode_state(text: str) -> list:
    """The nested list ``[buffer, activity, clock offset, counters]`` a stored state stands for (packed or JSON).

    Args:
        text: What :func:`encode_state` (or an older monitor's JSON) stored.

    Returns:
        What ``json.loads`` gives for the state's JSON form.
    """
    if not text.startswith(PACKED_PREFIX):
        return json.loads(text)
    blob = base64.b64decode(text[len(PACKED_PREFIX):])
    (bits, next_seq, fs, end_time, last_end, offset, started, energy, seconds, low_energy, low_seconds, low_since,
     rejected_s, gap_s, predicted, clock_offset, skipped_n, runs_n, boot_n, id_n, day_n, counters_n,
     _) = _HEAD.unpack_from(blob)
    at = _HEAD.size
    skipped = [list(_PAIR.unpack_from(blob, at + i * _PAIR.size)) for i in range(skipped_n)]
    at += skipped_n * _PAIR.size
    runs = [list(_RUN.unpack_from(blob, at + i * _RUN.size)) for i in range(runs_n)]
    at += runs_n * _RUN.size
    boot, at = blob[at:at + boot_n].decode(), at + boot_n
    activity_id, at = blob[at:at + id_n].decode(), at + id_n
    day, at = blob[at:at + day_n].decode(), at + day_n
    counters = {}
    for _ in range(counters_n):
        size = _NAME.unpack_from(blob, at)[0]
        name, at = blob[at + 2:at + 2 + size].decode(), at + 2 + size
        counters[name], at = (_INT_VALUE if blob[at] else _FLOAT_VALUE).unpack_from(blob, at)[1], at + 9
    buffer = [next_seq if bits & _NEXT_SEQ else None, fs, end_time if bits & _END_TIME else None, skipped,
              last_end if bits & _LAST_END else None, offset, [], boot if bits & _BOOT else None,
              bool(bits & _RESTART), runs]
    activity = [activity_id if bits & _ACTIVITY else None, day, started, energy, seconds, low_energy, low_seconds,
                low_since if bits & _LOW_SINCE else None, rejected_s, gap_s, predicted if bits & _PREDICTED else None]
    return [buffer, activity, clock_offset if bits & _OFFSET else None, counters]


class _Unpackable(Exception):
    """A value the packed form does not hold as it is (its JSON form does)."""


def _pack(buffer: Any, activity: Any, clock_offset_s: float | None, counters: dict[str, float]) -> bytes:
    """The packed state; _Unpackable (or struct.error) where a value would not come back as it is. Only the rate
    can be an int where a float belongs (an integer ``fs`` given by a caller): the times and the activity's
    figures are results of float arithmetic. Integers where a float is packed would come back as floats."""
    fs, next_seq, end_time, last_end, boot = buffer.fs, buffer.next_seq, buffer.end_time, buffer.last_end, buffer.boot
    act_id, low_since, predicted = activity.id, activity.low_since, activity.predicted_at_s
    if fs.__class__ is not _FLOAT:
        raise _Unpackable
    skipped, runs, day_b = buffer.skipped, buffer.runs, activity.day.encode()
    boot_b = b"" if boot is None else boot.encode()
    id_b = b"" if act_id is None else act_id.encode()
    bits = ((next_seq is not None) | (end_time is not None) << 1 | (last_end is not None) << 2
            | (boot is not None) << 3 | (buffer.restart_expected is True) << 4 | (act_id is not None) << 5
            | (low_since is not None) << 6 | (predicted is not None) << 7 | (clock_offset_s is not None) << 8)
    parts = [_HEAD.pack(bits, next_seq or 0, fs, end_time or 0.0, last_end or 0.0, buffer.offset,
                        activity.started, activity.energy, activity.seconds, activity.low_energy,
                        activity.low_seconds, low_since or 0.0, activity.rejected_s, activity.gap_s,
                        predicted or 0.0, clock_offset_s or 0.0, len(skipped), len(runs), len(boot_b), len(id_b),
                        len(day_b), len(counters), 0)]
    parts += [_PAIR.pack(lo, hi) for lo, hi in skipped]  # ints: struct refuses a float
    for run in runs:
        if run[0].__class__ is not _FLOAT or run[1].__class__ is not _FLOAT:  # an old state's integer times
            raise _Unpackable
        parts.append(_RUN.pack(*run))
    parts += (boot_b, id_b, day_b)
    heads = _COUNTER_HEADS
    for name, value in counters.items():
        head = heads.get(name) or _counter_head(name)
        if value.__class__ is _INT:
            parts += (head, _INT_VALUE.pack(True, value))
        elif value.__class__ is _FLOAT:
            parts += (head, _FLOAT_VALUE.pack(False, value))
        else:
            raise _Unpackable
    return b"".join(parts)


_COUNTER_HEADS: dict[str, bytes] = {}
"""A counter's name as packed (its byte length, then its bytes), by name: the monitor's counters are a handful of
names, packed for every stream of every commit."""


def _counter_head(name: str) -> bytes:
    """``name``'s packed head (struct.error for a name beyond 65535 bytes), kept for the first 256 names."""
    name_b = name.encode()
    head = _NAME.pack(len(name_b)) + name_b
    if len(_COUNTER_HEADS) < 256:
        _COUNTER_HEADS[name] = head
    return head
