"""Shared helpers of the safety tests: a settable clock and simulated tool sessions as batches."""

from __future__ import annotations

from bim2rdt.safety import HavMonitor, ListSink
from bim2rdt.sim.vibration import batches, session_signal

T0 = 1_700_000_000.0
"""Device time of the first sample in these tests: 2023-11-14T22:13:20Z."""
DAY = "2023-11-14"


class Clock:
    """A settable monitor clock (receive times), so tests control retention and reorder timeouts."""

    def __init__(self, now: float = T0):
        self.now = now

    def __call__(self) -> float:
        return self.now


def plan_batches(device: str, plan, fs: float = 5000.0, a_hv=None, batch_s: float = 0.5, seed: int = 0):
    """All batches of a (tool, seconds) work plan, starting at T0."""
    return list(batches(device, session_signal(plan, fs, seed, a_hv), fs, T0, batch_s))


def feed(monitor: HavMonitor, items, clock: Clock | None = None, chunk: int = 20) -> None:
    """Ingest in chunks, advancing the clock like real time if given."""
    for i in range(0, len(items), chunk):
        part = items[i:i + chunk]
        if clock is not None:
            clock.now = part[-1].device_time + part[-1].duration_s + 0.05
        monitor.ingest_many(part)


def main_kinds(sink: ListSink) -> list[str]:
    skip = {"hav.eav_predicted", "hav.artefact", "hav.gap"}
    return [k for k in sink.kinds() if k not in skip]
