"""A wearable's clock as the monitor sees it: the offset between our receive time and the device's sample time,
and where the device's samples belong on the wall clock.

MQTT carries no timestamp, so each batch's lag = receive time - device time of its last sample = clock skew +
delivery delay. The least delayed batches show the skew, so the estimate follows a smaller lag at once and a
larger one only slowly: a delivery hiccup barely moves it, a drifting clock still gets followed.

A device whose clock is no wall time (it counts from power-up, or its real-time clock lost its setting and
restarted at 1970 or 2000) sends times before ``WALL_CLOCK_FROM``. Its samples are placed on the receive clock:
device time + the estimated offset, so its exposure counts on the day it was taken (off by the least delivery
delay seen, milliseconds on a site network), not on 1970-01-01. The buffer still orders, de-duplicates and
finds gaps on the device's own times; only the times events and days are given move.

A clock that jumps back into that range within one boot (its real-time clock lost its setting and restarted at 0
while the device ran on) is treated as a reboot's clock is: the estimate the wall-time batches built cannot place
the new times (their lag is the whole epoch), so it is dropped and the next batch's lag taken at once, and its
samples land on the receive clock too.
"""

from __future__ import annotations

from dataclasses import dataclass

RISE_WEIGHT = 0.01
"""Share of a larger lag taken into the estimate per batch: the estimate rises over ~100 batches (clock drift of
a few ms per minute), so one late delivery moves it by 1 % of its delay."""
KEEP_WEIGHT = 1.0 - RISE_WEIGHT
"""Share of the previous estimate kept when a batch arrives later than estimated."""
WALL_CLOCK_FROM = 1_577_836_800.0
"""2020-01-01T00:00:00Z (UTC epoch seconds): a device time before it is no wall time. No wearable of this system
sampled before it; a clock counting from boot reads days at most, a reset real-time clock 1970 or 2000."""


@dataclass(slots=True)
class DeviceClock:
    """The estimated offset (s) of our clock ahead of the device's (None until a batch arrived)."""

    offset_s: float | None = None

    def observe(self, received_time: float, last_sample_time: float) -> float:
        """Take one in-order batch's lag into the estimate; returns the new offset, seconds."""
        lag = received_time - last_sample_time
        previous = self.offset_s
        if previous is not None and self._jumped_back(last_sample_time, received_time):
            previous = None  # the clock went back out of wall time: the old estimate cannot place it
        self.offset_s = lag if previous is None or lag < previous else KEEP_WEIGHT * previous + RISE_WEIGHT * lag
        return self.offset_s

    def _jumped_back(self, last_sample_time: float, received_time: float) -> bool:
        """Whether a sample time that is no wall time cannot be placed by the estimate while the receive clock
        could place it (it is wall time): the device's clock went back within its boot."""
        return (last_sample_time < WALL_CLOCK_FROM <= received_time
                and last_sample_time + self.offset_s < WALL_CLOCK_FROM)

    def shift(self, device_time: float) -> float:
        """Seconds to add to ``device_time`` to place it on the wall clock: 0 when it is wall time already; the
        estimated offset when it is not and the offset lands it on wall time (the receive clock is wall time);
        else 0 (nothing better is known: ``hav analyze`` reads a file from t = 0 on a clock that starts there)."""
        offset = self.offset_s
        if device_time >= WALL_CLOCK_FROM or offset is None or device_time + offset < WALL_CLOCK_FROM:
            return 0.0
        return offset
