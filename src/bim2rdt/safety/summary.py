"""On-device summaries as a stream type: one second of Wh-weighted r.m.s. per axis instead of raw samples.

Device side (:class:`SummaryDevice`, what a wearable's firmware does, used by the simulator and the tests): the
same fitted Wh IIR as the monitor (:mod:`~bim2rdt.safety.filters`), its state carried across seconds and settled
on the first sample, one :class:`~bim2rdt.bus.summaries.DeviceSummary` per whole second.

Monitor side (:func:`push_summaries`): a summary is one block for the stream's activity tracker, energy
``(a_hwx^2 + a_hwy^2 + a_hwz^2) x seconds``, rejected as an artefact when the device says it saturated. Summaries
arrive in order on a partition (NATS) or a device's MQTT session; per device the engine keeps the next expected
summary seq and the last summary's end in the stream's counters (persisted with the stream in the same commit):
a lower seq whose second starts before that end is a duplicate (a redelivery), a lower seq after it is a restarted
device's new numbering, a seq jump is a gap of the missing seconds. ``stream_kind`` tells raw from summary
streams for ``MonitorQueries.stream_status()``.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import scipy.signal

from bim2rdt.bus import DeviceSummary
from bim2rdt.safety.activity import GAP
from bim2rdt.safety.blocks import SATURATION

NEXT_SEQ, END, COUNT, GAP_S = "summary_next_seq", "summary_end", "summaries", "summary_gap_s"


class SummaryDevice:
    """A wearable that weighs its own samples and sends a summary per ``seconds`` (1 s)."""

    def __init__(self, device: str, fs: float, full_scale: float | None = None, seconds: float = 1.0,
                 saturation_ratio: float = 0.98):
        from bim2rdt.safety.filters import design_weighting

        self.device, self.fs, self.full_scale, self.seconds = device, fs, full_scale, seconds
        self.saturation_ratio = saturation_ratio
        self._sos = design_weighting(fs).sos
        self._settled = design_weighting(fs).settled_state
        self._per = int(round(seconds * fs))
        self.restart(0)

    def restart(self, seq: int = 0) -> None:
        """Power-up: filter unsettled, no samples carried, numbering from ``seq``."""
        self.seq, self._zi, self._carry, self._carry_t = seq, None, np.empty((0, 3)), None

    def feed(self, xyz: np.ndarray, t0: float) -> list[DeviceSummary]:
        """Samples (n, 3) m/s^2 starting at device time ``t0`` (continuing the last feed); the summaries of the
        whole seconds now complete (the rest waits for the next feed)."""
        xyz = np.asarray(xyz, dtype=np.float64)
        if self._carry_t is None or not len(self._carry):
            self._carry_t = t0
        samples = np.concatenate([self._carry, xyz]) if len(self._carry) else xyz
        whole = (len(samples) // self._per) * self._per
        out = []
        if whole:
            if self._zi is None:
                self._zi = self._settled(samples[0])
            weighted, self._zi = scipy.signal.sosfilt(self._sos, samples[:whole].T, axis=-1, zi=self._zi)
            rms = np.sqrt((weighted.reshape(3, -1, self._per) ** 2).mean(axis=-1))  # (3, seconds)
            peaks = np.abs(samples[:whole]).reshape(-1, self._per, 3).max(axis=1)  # (seconds, 3)
            limit = self.saturation_ratio * self.full_scale if self.full_scale else np.inf
            for i in range(whole // self._per):
                out.append(DeviceSummary(self.device, self.seq, self._carry_t + i * self.seconds, self.seconds,
                                         self.fs, tuple(float(v) for v in rms[:, i]),
                                         tuple(float(v) for v in peaks[i]), bool(peaks[i].max() >= limit),
                                         self.full_scale))
                self.seq += 1
            self._carry_t += (whole // self._per) * self.seconds
        self._carry = samples[whole:]
        return out


def split_summaries(items: Iterable) -> tuple[list, list[DeviceSummary]]:
    """(raw batches, summaries) of a mixed list, each in the order given."""
    batches, summaries = [], []
    for item in items:
        (summaries if isinstance(item, DeviceSummary) else batches).append(item)
    return batches, summaries


def merge_outcomes(first, second):
    """One Outcome of two ingests (accepted batches, streams, events in order)."""
    first.accepted += second.accepted
    first.streams.update(second.streams)
    first.events += second.events
    return first


def stream_kind(counters: dict[str, float]) -> str:
    """'raw', 'summary', 'mixed' (both seen) or 'none', from a stream's counters."""
    raw, summaries = counters.get("batches", 0) > 0, counters.get(COUNT, 0) > 0
    return "mixed" if raw and summaries else "summary" if summaries else "raw" if raw else "none"


def push_summaries(engine, summaries: Iterable[DeviceSummary], now: float):
    """Frame ``summaries`` (any devices, each device's in order) on their streams; the engine's Outcome."""
    from bim2rdt.safety.engine import Outcome

    outcome = Outcome()
    for summary in summaries:
        stream = engine.stream(summary.device)
        outcome.streams[stream.device] = stream
        missing_s = _take(stream, summary)
        if missing_s is None:
            stream.count("duplicates")
            engine.count("duplicates")
            continue
        received = summary.received_time if summary.received_time is not None else now
        stream.clock.observe(received, summary.end_time)
        outcome.events += _frame(engine, stream, summary, missing_s)
    return outcome


def _take(stream, summary: DeviceSummary) -> float | None:
    """None if the summary was counted already; else the seconds missing before it (a seq jump). Moves the
    stream's next expected summary seq and end on."""
    counters = stream.counters
    expected, end = counters.get(NEXT_SEQ), counters.get(END)
    if expected is not None and summary.seq < expected and summary.device_time < end - 1e-6:
        return None  # already counted: a redelivery
    missing_s = (summary.seq - expected) * summary.seconds if expected is not None and summary.seq > expected else 0.0
    counters[NEXT_SEQ], counters[END] = summary.seq + 1, summary.end_time
    stream.count(COUNT)
    return missing_s


def _frame(engine, stream, summary: DeviceSummary, missing_s: float) -> list:
    """The summary as one tracker block (after a gap event for missing seconds)."""
    end = stream.placed(summary.end_time)
    events = []
    if missing_s:
        stream.count("gaps")
        stream.count(GAP_S, missing_s)
        engine.count("gaps")
        stream.tracker.gap(missing_s)
        start = end - summary.seconds
        events.append(engine.event(stream, (GAP, start - missing_s, {"end": start, "seconds": missing_s,
                                                                     "reason": "missing summaries"})))
    flags = SATURATION if summary.saturated else 0
    day_of = engine._day_lookup(stream.session.subject)
    return events + engine._frame(stream, day_of, end, summary.seconds, summary.energy, flags)
