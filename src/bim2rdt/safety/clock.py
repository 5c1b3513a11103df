"""A wearable's clock as the monitor sees it: the offset between our receive time and the device's sample time.

MQTT carries no timestamp, so each batch's lag = receive time - device time of its last sample = clock skew +
delivery delay. The least delayed batches show the skew, so the estimate follows a smaller lag at once and a
larger one only slowly: a delivery hiccup barely moves it, a drifting clock still gets followed.
"""

from __future__ import annotations

from dataclasses import dataclass

RISE_WEIGHT = 0.01
"""Share of a larger lag taken into the estimate per batch: the estimate rises over ~100 batches (clock drift of
a few ms per minute), so one late delivery moves it by 1 % of its delay."""
KEEP_WEIGHT = 1.0 - RISE_WEIGHT
"""Share of the previous estimate kept when a batch arrives later than estimated."""


@dataclass
class DeviceClock:
    """The estimated offset (s) of our clock ahead of the device's (None until a batch arrived)."""

    offset_s: float | None = None

    def observe(self, received_time: float, last_sample_time: float) -> float:
        """Take one in-order batch's lag into the estimate; returns the new offset, seconds."""
        lag = received_time - last_sample_time
        previous = self.offset_s
        self.offset_s = lag if previous is None or lag < previous else KEEP_WEIGHT * previous + RISE_WEIGHT * lag
        return self.offset_s
