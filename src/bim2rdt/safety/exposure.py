"""ISO 5349-1 exposure arithmetic, Directive 2002/44/EC limits and the UK HSE points system.

All accelerations are frequency-weighted r.m.s. values in m/s^2, all durations in seconds.
- vibration total value a_hv = sqrt(a_hwx^2 + a_hwy^2 + a_hwz^2)
- daily exposure A(8) = a_hv sqrt(T / T0), T0 = 8 h; several tools: A(8) = sqrt(sum A_i(8)^2)
- exposure action value EAV = 2.5 m/s^2 A(8), exposure limit value ELV = 5 m/s^2 A(8)
- HSE points = 2 a_hv^2 T_hours (EAV = 100 points, ELV = 400 points); points add across tools
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from bim2rdt.safety.errors import HavError

T0_S = 8 * 3600.0
"""Reference duration of the daily exposure A(8), seconds."""
EAV = 2.5
"""Exposure action value, m/s^2 A(8) (Directive 2002/44/EC Art. 3)."""
ELV = 5.0
"""Exposure limit value, m/s^2 A(8)."""
POINTS_PER_HOUR_PER_MS2_SQUARED = 2.0
EAV_POINTS = 100.0
ELV_POINTS = 400.0


def a_hv(a_hwx: float, a_hwy: float, a_hwz: float) -> float:
    """The vibration total value (ISO 5349-1): the root sum of squares of the three axes.

    Args:
        a_hwx: Frequency-weighted r.m.s. acceleration along x, m/s^2.
        a_hwy: Frequency-weighted r.m.s. acceleration along y, m/s^2.
        a_hwz: Frequency-weighted r.m.s. acceleration along z, m/s^2.

    Returns:
        a_hv, m/s^2.
    """
    return float(np.sqrt(a_hwx**2 + a_hwy**2 + a_hwz**2))


def daily_exposure(a_hv_ms2: float, seconds: float) -> float:
    """The daily exposure A(8) of one tool: a_hv sqrt(T / 8 h).

    Args:
        a_hv_ms2: Vibration total value, m/s^2.
        seconds: Exposure time, seconds.

    Returns:
        A(8), m/s^2.

    Raises:
        HavError: A negative or non-finite value.
    """
    _check_exposure(a_hv_ms2, seconds)
    return float(a_hv_ms2 * np.sqrt(seconds / T0_S))


def combine_exposures(exposures: Iterable[tuple[float, float]]) -> float:
    """The daily exposure A(8) of a day with several tools: sqrt(sum A_i(8)^2).

    Args:
        exposures: (a_hv in m/s^2, seconds) per tool.

    Returns:
        A(8), m/s^2.

    Raises:
        HavError: A negative or non-finite value.
    """
    return float(np.sqrt(sum(daily_exposure(a, t) ** 2 for a, t in exposures)))


def exposure_points(a_hv_ms2: float, seconds: float) -> float:
    """HSE exposure points: 2 a_hv^2 T_hours; 100 points is the EAV, 400 the ELV.

    Args:
        a_hv_ms2: Vibration total value, m/s^2.
        seconds: Exposure time, seconds.

    Returns:
        The points.

    Raises:
        HavError: A negative or non-finite value.
    """
    _check_exposure(a_hv_ms2, seconds)
    return float(POINTS_PER_HOUR_PER_MS2_SQUARED * a_hv_ms2**2 * seconds / 3600.0)


def time_to_limit(a_hv_ms2: float, limit: float = EAV) -> float:
    """How long a tool may run until A(8) reaches a limit: 8 h (limit / a_hv)^2.

    Args:
        a_hv_ms2: Vibration total value, m/s^2.
        limit: The A(8) to reach, m/s^2 (the EAV by default).

    Returns:
        Seconds; inf at a_hv 0.

    Raises:
        HavError: A negative or non-finite a_hv.
    """
    _check_exposure(a_hv_ms2, 0.0)
    if a_hv_ms2 == 0:
        return float("inf")
    return float(T0_S * (limit / a_hv_ms2) ** 2)


def a8_from_energy(energy: float) -> float:
    """A(8) from accumulated weighted energy sum(a_hv^2 dt) in m^2/s^3 (the streaming monitor's currency)."""
    return float(np.sqrt(max(energy, 0.0) / T0_S))


def points_from_energy(energy: float) -> float:
    """HSE points from accumulated weighted energy sum(a_hv^2 dt) in m^2/s^3."""
    return float(POINTS_PER_HOUR_PER_MS2_SQUARED * max(energy, 0.0) / 3600.0)


def a8_to_points(a8: float) -> float:
    """HSE points equivalent to a daily exposure A(8): 400 points is 5.0 m/s^2."""
    return float(EAV_POINTS * (a8 / EAV) ** 2)


def _check_exposure(a: float, seconds: float) -> None:
    if not (np.isfinite(a) and a >= 0 and np.isfinite(seconds) and seconds >= 0):
        raise HavError(f"exposure needs a_hv >= 0 m/s^2 and duration >= 0 s, got {a!r} and {seconds!r}")
