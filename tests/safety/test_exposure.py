"""The worked examples of hav.md (ISO 5349-1, Directive 2002/44/EC, HSE points)."""

from __future__ import annotations

import pytest

from bim2rdt.safety import (EAV, ELV, HavError, a_hv, combine_exposures, daily_exposure, exposure_points,
                            time_to_limit)

HOUR = 3600.0


def test_limits_are_the_directive_values():
    assert (EAV, ELV) == (2.5, 5.0)


def test_vibration_total_value_is_the_root_sum_of_squares():
    assert a_hv(3.0, 4.0, 12.0) == pytest.approx(13.0)


def test_5_ms2_for_3_hours_is_150_points():
    assert exposure_points(5.0, 3 * HOUR) == pytest.approx(150.0)


def test_7_4_ms2_for_2_5_hours_is_a8_4_1():
    assert daily_exposure(7.4, 2.5 * HOUR) == pytest.approx(4.137, abs=5e-4)


def test_three_tools_combine_to_a8_3_4():
    day = [(2.0, 1 * HOUR), (3.5, 3 * HOUR), (10.0, 0.5 * HOUR)]
    assert combine_exposures(day) == pytest.approx(3.368, abs=5e-4)


def test_10_ms2_reaches_eav_after_30_minutes_and_elv_after_2_hours():
    assert time_to_limit(10.0) == pytest.approx(0.5 * HOUR)
    assert time_to_limit(10.0, limit=ELV) == pytest.approx(2 * HOUR)


@pytest.mark.parametrize("a, hours", [(5.0, 8.0), (10.0, 2.0), (20.0, 0.5)])
def test_400_points_is_a8_5(a, hours):
    assert exposure_points(a, hours * HOUR) == pytest.approx(400.0)
    assert daily_exposure(a, hours * HOUR) == pytest.approx(5.0)


def test_no_vibration_never_reaches_a_limit():
    assert time_to_limit(0.0) == float("inf")


@pytest.mark.parametrize("a, seconds", [(-1.0, 10.0), (2.0, -5.0), (float("nan"), 1.0)])
def test_negative_or_nan_inputs_raise(a, seconds):
    with pytest.raises(HavError):
        daily_exposure(a, seconds)
