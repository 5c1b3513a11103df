"""The accel wire format: header + packed samples."""

from __future__ import annotations

import numpy as np
import pytest

from bim2rdt.bus import AccelBatch, PayloadError, decode_accel, encode_accel


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
