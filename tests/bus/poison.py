"""Hypothesis strategies for hostile wearable messages: each one is invalid by construction (no strategy can
yield a well-formed batch or status), so a monitor must refuse every one and count it."""

from __future__ import annotations

import json
import struct

from hypothesis import strategies as st

MAGIC = b"HAV1"
GOOD = {"device": "w1", "seq": 0, "t_ms": 1.7e12, "fs": 5000.0, "n": 4, "dtype": "int16", "scale": 0.06,
        "full_scale": 1961.3}
SAMPLES = bytes(24)  # 4 int16 samples x 3 axes: what GOOD announces
REQUIRED = ("device", "seq", "t_ms", "fs", "n", "dtype")

junk = st.recursive(st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=6),
                    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=4), inner, max_size=3),
                    max_leaves=6)
not_a_number = st.none() | st.booleans() | st.text(max_size=6) | st.lists(junk, max_size=2) | st.dictionaries(
    st.text(max_size=3), junk, max_size=2)
not_finite = st.sampled_from([float("nan"), float("inf"), float("-inf")])

BAD_FIELDS = {
    "device": st.one_of(st.just(""), st.text(alphabet="ab", min_size=65, max_size=70),
                        st.text(alphabet=" /#+\n", min_size=1, max_size=3), st.sampled_from(["w2", "w1 ", "W1"]),
                        st.integers(), st.none(), st.lists(junk, max_size=2)),
    "seq": st.one_of(st.integers(max_value=-1), st.integers(min_value=2**53), st.floats(), not_finite,
                     not_a_number),
    "t_ms": st.one_of(st.floats(max_value=-1e-3, allow_nan=False), st.floats(min_value=4.2e12), not_finite,
                      not_a_number),
    "fs": st.one_of(st.floats(max_value=0.0, allow_nan=False), st.floats(min_value=100_001.0),
                    st.floats(min_value=1e-6, max_value=5.0), not_finite, not_a_number),
    "n": st.one_of(st.integers().filter(lambda n: n != 4), st.floats(), not_a_number),
    "dtype": st.one_of(st.text(max_size=8).filter(lambda t: t not in ("int16", "float32")), st.integers(),
                       st.none(), st.lists(junk, max_size=2)),
    "scale": st.one_of(st.floats(max_value=0.0, allow_nan=False), not_finite, not_a_number.filter(
        lambda v: v is not None)),
    "full_scale": st.one_of(st.floats(max_value=0.0, allow_nan=False), not_finite,
                            not_a_number.filter(lambda v: v is not None)),
}


def _frame(head: bytes, samples: bytes = SAMPLES) -> bytes:
    return MAGIC + struct.pack("<H", len(head) % 65536) + head + samples


@st.composite
def bad_field(draw) -> bytes:
    field = draw(st.sampled_from(sorted(BAD_FIELDS)))
    return _frame(json.dumps({**GOOD, field: draw(BAD_FIELDS[field])}).encode())


@st.composite
def missing_field(draw) -> bytes:
    field = draw(st.sampled_from(REQUIRED))
    return _frame(json.dumps({k: v for k, v in GOOD.items() if k != field}).encode())


@st.composite
def bad_framing(draw) -> bytes:
    good = _frame(json.dumps(GOOD).encode())
    kind = draw(st.sampled_from(["truncated", "extended", "magic", "length", "nested", "not-object", "bytes"]))
    if kind == "truncated":
        return good[:draw(st.integers(0, len(good) - 1))]
    if kind == "extended":
        return good + draw(st.binary(min_size=1, max_size=64))
    if kind == "magic":
        return draw(st.binary(min_size=4, max_size=4).filter(lambda m: m != MAGIC)) + good[4:]
    if kind == "length":
        true = len(good) - 6 - len(SAMPLES)
        return MAGIC + struct.pack("<H", draw(st.integers(0, 65535).filter(lambda n: n != true))) + good[6:]
    if kind == "nested":
        depth = draw(st.integers(1, 40000))
        return _frame(b"[" * depth + b"]" * draw(st.integers(0, depth)))
    if kind == "not-object":
        return _frame(json.dumps(draw(junk.filter(lambda v: not isinstance(v, dict)))).encode())
    return draw(st.binary(max_size=300))


poison_accel = st.one_of(bad_field(), missing_field(), bad_framing())
"""An accel payload no monitor may count (its topic's device is w1)."""

BAD_STATUS = st.one_of(
    st.binary(max_size=200).filter(lambda b: not b.strip().startswith(b"{")),
    junk.filter(lambda v: not isinstance(v, dict)).map(lambda v: json.dumps(v).encode()),
    st.dictionaries(st.sampled_from(["worker", "tool", "zone"]), junk, max_size=3).map(lambda d: json.dumps(d).encode()),
    st.builds(lambda online, worker: json.dumps({"online": online, "worker": worker}).encode(),
              junk.filter(lambda v: not isinstance(v, bool)), junk),
    st.builds(lambda worker: json.dumps({"online": True, "worker": worker}).encode(),
              st.one_of(st.just(""), st.text(min_size=129, max_size=140), st.integers(), st.lists(junk, max_size=2))),
    st.builds(lambda hand: json.dumps({"online": True, "worker": "x", "hand": hand}).encode(),
              st.text(max_size=6).filter(lambda h: h not in ("", "left", "right"))),
)
"""A status payload no monitor may act on."""
