"""The HAV monitor's configuration: one validated object, also ``Settings.hav`` (``BIM2RDT_HAV__*``).

Only pydantic is imported here, so reading the settings never loads the signal-processing stack. The monitor's
parts take the plain values they need: :class:`Trigger` (activity detection) and :class:`ArtefactLimits`
(artefact rejection) are built from the flat fields, which keep the environment names short
(``BIM2RDT_HAV__START_THRESHOLD``, not ``..._TRIGGER__START_THRESHOLD``).
"""

from __future__ import annotations

from dataclasses import dataclass

from pydantic import BaseModel, ConfigDict, Field, model_validator

PHYSICAL_LIMIT = 5000.0
"""m/s^2: no hand-held tool shakes a hand harder (percussive tools peak at a few hundred m/s^2 unweighted); a
sample beyond it is a sensor or transmission artefact, never exposure (ISO 8041-2 artefact rejection)."""


@dataclass(frozen=True)
class Trigger:
    """Activity detection: start at ``start_threshold`` m/s^2, stop after ``stop_hold_s`` s under
    ``stop_threshold`` m/s^2; re-predict the time to EAV every ``predict_every_s`` s of activity."""

    start_threshold: float = 1.0
    stop_threshold: float = 0.5
    stop_hold_s: float = 2.0
    predict_every_s: float = 60.0


@dataclass(frozen=True)
class ArtefactLimits:
    """When a block is rejected (see :mod:`bim2rdt.safety.blocks`)."""

    saturation_ratio: float = 0.98
    crest_limit: float = 25.0
    shock_min_peak: float = 100.0
    physical_limit: float = PHYSICAL_LIMIT


MAX_MESSAGE_BYTES = 64 * 1024
"""Default bound of one wearable message, bytes. The project's wearables send 0.5 s batches at 5 kHz: 30 kB as
float32, 15 kB as int16 counts; 64 KiB keeps them at under half of it (and 0.5 s at 10 kHz float32 still fits)."""


class MonitorConfig(BaseModel):
    """How the monitor detects activities, rejects artefacts, orders batches, commits and keeps raw data."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    site: str = Field("demo", description="Site id of the topics the monitor reads, site/{site}/wearable/+/...; "
                      "in Settings it is always mqtt.site (BIM2RDT_MQTT__SITE).")
    start_threshold: float = Field(1.0, gt=0, description="Block a_hv (m/s^2) at which a tool activity starts "
                                   "(trigger time, as an ISO 8041-2 meter counts it).")
    stop_threshold: float = Field(0.5, gt=0, description="Block a_hv (m/s^2) under which an activity is winding "
                                  "down; at most start_threshold.")
    stop_hold_s: float = Field(2.0, ge=0, le=3600, description="Seconds under stop_threshold that end an activity.")
    predict_every_s: float = Field(60.0, gt=0, description="Activity seconds between predictions of the time to EAV.")
    crest_limit: float = Field(25.0, gt=1, description="Crest factor above which a block is a shock artefact.")
    saturation_ratio: float = Field(0.98, gt=0, le=1, description="Share of the sensor's full scale at which a "
                                    "block counts as saturated.")
    shock_min_peak: float = Field(100.0, gt=0, description="Smallest centred peak (m/s^2) a shock artefact has.")
    max_reorder: int = Field(8, ge=0, le=10_000, description="Out-of-order batches held before a missing one is "
                             "declared a gap.")
    reorder_s: float = Field(2.0, ge=0, le=3600, description="Seconds a batch waits for a missing predecessor "
                             "before a gap is declared.")
    raw_retention_s: float = Field(7 * 24 * 3600.0, ge=0, description="Raw batches are deleted this long after "
                                   "receipt once framed, seconds (0: as soon as framed); until then only the recent "
                                   "ones and those around events are kept (raw_recent_s, raw_event_margin_s).")
    raw_recent_s: float = Field(60.0, ge=0, le=86400, description="Every raw batch within this many seconds of its "
                                "device's newest sample (device time) is kept: the dashboard's live raw view.")
    raw_event_margin_s: float = Field(10.0, ge=0, le=3600, description="Older raw batches are kept (compressed) "
                                      "only within this many seconds of an activity start or end, an EAV/ELV "
                                      "crossing or an artefact on their device.")
    raw_max_mb: float = Field(256.0, gt=0, description="Raw samples in the store are bounded by this size (MB); "
                              "the oldest received go first.")
    store_url: str | None = Field(None, min_length=1, description="SQLAlchemy URL of the exposure store: "
                                  "sqlite:///path/hav.sqlite for one monitor process, postgresql+psycopg://user:"
                                  "password@host/db for several; None: hav.sqlite in the monitor's data folder.")
    outbox_retry_s: float = Field(1.0, gt=0, le=600, description="Seconds between deliveries of queued events "
                                  "to a durable sink (the twin) that failed.")
    outbox_drain_s: float = Field(5.0, ge=0, le=600, description="Seconds closing the monitor waits for the "
                                  "durable sinks to take what is queued (the rest is delivered at the next start).")
    keep_timeline: bool = Field(False, description="Keep (time, subject, A(8)) after every counted block (plots).")
    commit_batches: int = Field(64, ge=1, le=1000, description="Group commit: bus messages ingested and committed "
                                "together at most (one SQLite transaction, one filtering pass per stream).")
    commit_delay_s: float = Field(0.25, ge=0, le=10, description="Group commit: the longest a received batch waits "
                                  "for its commit, seconds (0: every message commits alone).")
    max_message_bytes: int = Field(MAX_MESSAGE_BYTES, ge=4096, le=2**20, description="Largest wearable message, "
                                   "bytes: the monitor dead-letters a longer one before decoding it, and the NATS "
                                   "stream refuses to store it (decision 0037).")
    settle_heap: bool = Field(True, description="Take the monitor's long-lived objects out of the cyclic garbage "
                              "collector's full passes (gc.freeze) at its 64th stream and each time its streams have "
                              "doubled, closing it gives them back, and hold the collector's young passes to the end "
                              "of each ingest (decision 0051). The collector is the process's: false where the "
                              "application manages it itself.")

    @model_validator(mode="after")
    def _stop_not_above_start(self) -> MonitorConfig:
        if self.stop_threshold > self.start_threshold:
            raise ValueError(f"stop_threshold ({self.stop_threshold}) must not exceed start_threshold "
                             f"({self.start_threshold})")
        return self

    @property
    def trigger(self) -> Trigger:
        """The activity trigger's thresholds (m/s^2), stop hold and prediction period (seconds)."""
        return Trigger(self.start_threshold, self.stop_threshold, self.stop_hold_s, self.predict_every_s)

    @property
    def artefacts(self) -> ArtefactLimits:
        """The limits that flag a signal as an artefact: saturation ratio, crest factor, shock peak."""
        return ArtefactLimits(self.saturation_ratio, self.crest_limit, self.shock_min_peak)
