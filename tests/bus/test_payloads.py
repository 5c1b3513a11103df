"""The accel wire format: header + packed samples."""

from __future__ import annotations

import json
import struct

import numpy as np
import pytest

from bim2rdt.bus import AccelBatch, PayloadError, decode_accel, encode_accel
from bim2rdt.bus.payloads import MAGIC


def batch(xyz) -> AccelBatch:
    return AccelBatch("w1", 17, 1_700_000_000.125, 5000.0, np.asarray(xyz, dtype=np.float32), 1961.3)


def test_int16_round_trip_keeps_samples_within_one_count():
    xyz = np.random.default_rng(0).normal(0, 50, (500, 3))
    back = decode_accel(encode_accel(batch(xyz)))
    assert (back.device, back.seq, back.fs, back.full_scale) == ("w1", 17, 5000.0, 1961.3)
    assert back.device_time == pytest.approx(1_700_000_000.125, abs=1e-6)
    np.testing.assert_allclose(back.xyz, xyz, atol=1961.3 / 32767)


def test_float32_round_trip_keeps_nan():
    xyz = np.ones((4, 3))
    xyz[1, 2] = np.nan
    back = decode_accel(encode_accel(batch(xyz), dtype="float32"))
    assert np.isnan(back.xyz[1, 2]) and back.xyz[0, 0] == 1.0


@pytest.mark.parametrize("payload", [b"", b"JSON{}", b"HAV1\x05\x00{bad}"])
def test_garbage_is_a_payload_error(payload):
    with pytest.raises(PayloadError):
        decode_accel(payload)


@pytest.mark.parametrize("fs", [0.0, -5000.0, float("nan"), float("inf")])
def test_a_header_without_a_usable_sampling_rate_is_a_payload_error(fs):
    with pytest.raises(PayloadError, match="sampling rate"):
        decode_accel(encode_accel(AccelBatch("w1", 0, 1_700_000_000.0, fs, np.ones((4, 3), np.float32)),
                                  dtype="float32"))


@pytest.mark.parametrize("field, value, message", [("n", 0, "sample count"), ("n", -1, "sample count"),
                                                   ("t_ms", float("nan"), "device time")])
def test_a_header_with_no_samples_or_no_time_is_a_payload_error(field, value, message):
    header = {"device": "w1", "seq": 0, "t_ms": 1.7e12, "fs": 1000.0, "n": 4, "dtype": "float32", "scale": 1.0}
    head = json.dumps({**header, field: value}).encode()
    payload = MAGIC + struct.pack("<H", len(head)) + head + np.ones(12, "<f4").tobytes()
    with pytest.raises(PayloadError, match=message):
        decode_accel(payload)


def _payload(header: dict | bytes, samples: bytes = b"\0" * 24) -> bytes:
    head = header if isinstance(header, bytes) else json.dumps(header).encode()
    return MAGIC + struct.pack("<H", len(head)) + head + samples


GOOD = {"device": "w1", "seq": 0, "t_ms": 1.7e12, "fs": 1000.0, "n": 4, "dtype": "int16", "scale": 0.06,
        "full_scale": 1961.3}


def test_the_reference_header_decodes():
    assert decode_accel(_payload(GOOD)).seq == 0


@pytest.mark.parametrize("field, value, message", [
    ("full_scale", {}, "full scale"), ("full_scale", -1.0, "full scale"), ("t_ms", 1e300, "device time"),
    ("t_ms", -5.0, "device time"), ("fs", 1e12, "sampling rate"), ("seq", 1e20, "sequence number"),
    ("seq", 2**53, "sequence number"), ("seq", -1, "sequence number"), ("seq", "7", "sequence number"),
    ("seq", True, "sequence number"), ("n", 4.0, "sample count"), ("scale", 0, "count scale"),
    ("scale", "big", "count scale"), ("dtype", "int64", "sample type"), ("device", "w 1", "device id"),
    ("device", 7, "device id")])
def test_a_header_field_out_of_type_or_bounds_is_a_payload_error_naming_it(field, value, message):
    with pytest.raises(PayloadError, match=message):
        decode_accel(_payload({**GOOD, field: value}))


@pytest.mark.parametrize("header", [b"[" * 30000, b"[" * 900 + b"]" * 900, b'{"a":' * 400 + b"1" + b"}" * 400,
                                    b"\xff\xfe{}", b"[1, 2]", b"null"])
def test_a_huge_nested_or_non_object_header_is_a_payload_error(header):
    with pytest.raises(PayloadError):
        decode_accel(_payload(header))


@pytest.mark.parametrize("samples", [b"\0" * 23, b"\0" * 25, b""])
def test_samples_must_fill_the_payload_exactly(samples):
    with pytest.raises(PayloadError, match="header says"):
        decode_accel(_payload(GOOD, samples))


def test_a_header_length_beyond_the_payload_is_a_payload_error():
    with pytest.raises(PayloadError, match="header of"):
        decode_accel(MAGIC + struct.pack("<H", 500) + b"{}")


def test_a_batch_longer_than_a_minute_is_refused():
    with pytest.raises(PayloadError, match="more than 60 s"):
        decode_accel(_payload({**GOOD, "n": 70_000, "fs": 1000.0}, b"\0" * 70_000 * 6))
