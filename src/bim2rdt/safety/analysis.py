"""Exposure of a recording (:mod:`~bim2rdt.safety.recording`): run it through the monitor, plot the day.

The recording goes through the same :class:`HavMonitor` as live data, configured like the live one
(trigger-time activities, artefact rejection), so a file and a stream give the same figures.
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bim2rdt.atomic import WriteError, write_bytes_atomic
from bim2rdt.bus import Event
from bim2rdt.bus import AccelBatch
from bim2rdt.safety.activity import ACTIVITY_ENDED, ARTEFACT
from bim2rdt.safety.config import MonitorConfig
from bim2rdt.safety.errors import HavError
from bim2rdt.safety.exposure import EAV, ELV, a8_from_energy, time_to_limit
from bim2rdt.safety.monitor import HavMonitor
from bim2rdt.safety.recording import Recording, read_accel_csv
from bim2rdt.safety.sinks import ListSink
from bim2rdt.safety.weighting import BandCoverage, covered_band

__all__ = ["DayReport", "Recording", "analyze_recording", "plot_day", "read_accel_csv"]

GROUP = 64
"""Batches of a recording ingested together."""
UNTRIGGERED_NOTE_A8 = 0.01
"""m/s^2: vibration under the trigger worth a note (it would show at the report's two decimals)."""


@dataclass
class DayReport:
    """What a recording amounts to: activities, the day's A(8) and points, its A(8) curve and all events;
    ``rejected_s`` seconds of samples were artefacts (``rejected_kinds``) and count as no exposure."""

    a8: float
    points: float
    trigger_s: float
    band: BandCoverage
    activities: list[dict] = field(default_factory=list)
    timeline: list[tuple[float, float]] = field(default_factory=list)
    events: list[Event] = field(default_factory=list)
    rejected_s: float = 0.0
    rejected_kinds: list[str] = field(default_factory=list)
    untriggered_s: float = 0.0
    """Seconds of clean blocks under the activity trigger (not counted as exposure)."""
    untriggered_energy: float = 0.0
    """Their weighted energy, m^2/s^3."""
    notes: list[str] = field(default_factory=list)
    """What limits the figures: the recording's units or gaps, exposure left under the trigger."""

    @property
    def untriggered_a8(self) -> float:
        """The A(8) the vibration under the trigger would add, on its own."""
        return a8_from_energy(self.untriggered_energy)

    @property
    def seconds_to_eav(self) -> float | None:
        """At the last activity's a_hv, how long until EAV (None once reached or without activity)."""
        return self._remaining(EAV)

    @property
    def seconds_to_elv(self) -> float | None:
        return self._remaining(ELV)

    def _remaining(self, limit: float) -> float | None:
        if not self.activities or self.a8 >= limit:
            return None
        a_hv = self.activities[-1]["a_hv"]
        return time_to_limit(a_hv, limit) * (1 - (self.a8 / limit) ** 2)


def analyze_recording(recording: Recording, tool: str = "unknown", position: str = "handle",
                      batch_s: float = 1.0, config: MonitorConfig = MonitorConfig()) -> DayReport:
    """Run a recording through a throw-away monitor configured like the live one (``config``) and collect the
    day."""
    sink = ListSink()
    config = config.model_copy(update={"keep_timeline": True, "raw_retention_s": 0.0})  # the file is the raw data
    monitor = HavMonitor(None, "analysis", [sink], config, clock=lambda: recording.t0)  # in memory: writes nothing
    subject = monitor.start_session("file", "recording", tool, position)
    step = max(1, int(round(batch_s * recording.fs)))
    batches = [AccelBatch("file", seq, recording.t0 + start / recording.fs, recording.fs,
                          recording.xyz[start:start + step].astype(np.float32), None)
               for seq, start in enumerate(range(0, recording.xyz.shape[0], step))]
    for first in range(0, len(batches), GROUP):  # groups, as on the bus: one filtering pass per group
        monitor.ingest_many(batches[first:first + GROUP])
    monitor.end_session("file")
    days = monitor.queries.days_of(subject)
    day = monitor.queries.day(subject, days[-1] if days else None)
    timeline = [(t, a8) for t, _, a8 in monitor.queries.timeline]
    status = monitor.queries.stream_status("file") or {}
    monitor.close()
    ended = [e.data for e in sink.events if e.kind == ACTIVITY_ENDED]
    artefacts = [e.data for e in sink.events if e.kind == ARTEFACT]
    kinds = sorted({kind for data in artefacts for kind in data["kinds"]})
    report = DayReport(day.a8, day.points, day.seconds, covered_band(recording.fs), ended, timeline, sink.events,
                       sum(data["seconds"] for data in artefacts), kinds, status.get("untriggered_s", 0.0),
                       status.get("untriggered_energy", 0.0), list(recording.notes))
    if report.untriggered_a8 >= UNTRIGGERED_NOTE_A8:
        report.notes.append(f"{report.untriggered_s / 60:.1f} min of vibration stayed under the "
                            f"{config.start_threshold:g} m/s² activity trigger: A(8) {report.untriggered_a8:.3f} "
                            f"m/s² on its own, not counted (lower BIM2RDT_HAV__START_THRESHOLD to count it)")
    return report


def plot_day(report: DayReport, path: Path, title: str = "Daily vibration exposure") -> Path:
    """A(8) against time (hours from the first activity) with the EAV and ELV lines, as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.5))
    if report.timeline:
        t = np.array([row[0] for row in report.timeline])
        ax.plot((t - t[0]) / 3600.0, [row[1] for row in report.timeline], color="tab:blue", label="A(8)")
    ax.axhline(EAV, color="tab:orange", linestyle="--", label=f"EAV {EAV} m/s²")
    ax.axhline(ELV, color="tab:red", linestyle="--", label=f"ELV {ELV} m/s²")
    ax.set(xlabel="time since first activity (h)", ylabel="A(8) (m/s²)", title=title,
           ylim=(0, max(ELV * 1.2, report.a8 * 1.1)))
    ax.legend(loc="upper left")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    image = io.BytesIO()
    fig.savefig(image, format="png", dpi=120)
    plt.close(fig)
    try:  # atomically: a full disk leaves the old plot (or none), never a truncated or empty PNG
        return write_bytes_atomic(Path(path), image.getvalue())
    except WriteError as error:  # its message names the path and the system's reason
        raise HavError(str(error).replace("cannot write ", "cannot write the plot ", 1)) from None
