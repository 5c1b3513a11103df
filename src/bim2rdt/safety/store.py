"""Exposure state on disk: SQLite in WAL mode, one transaction per ingest, so a restart loses nothing.

What is kept: raw batches (out-of-order ones until they are processed, all of them only for the configured
retention), each stream's ordering, filter and activity state, each worker-day's accumulated weighted energy and
the times EAV
and ELV were reached, activities, events and fitted mounting corrections. Workers appear only as pseudonyms;
the identity map lives in a separate file (see :mod:`bim2rdt.safety.privacy`).
"""

from __future__ import annotations

import json
import sqlite3
import time
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from bim2rdt.bus.event import Event
from bim2rdt.bus.payloads import MAX_BATCH_S, AccelBatch

PAGE_SIZE = 16384
"""Bytes per SQLite page. A 0.5 s int16 batch at 5 kHz is 15 kB: on 4 kB pages it spans an overflow chain of
four pages, each written to the WAL and again at the checkpoint; 16 kB pages cut the commit cost per batch from
58 to 38 us (2 wearables x 15 min, median of 3 interleaved runs) without making small-row updates heavy."""

_SCHEMA = """
CREATE TABLE IF NOT EXISTS raw (device TEXT, seq INTEGER, device_time REAL, received_time REAL, fs REAL,
    full_scale REAL, n INTEGER, samples BLOB, scale REAL, PRIMARY KEY (device, seq));
DROP INDEX IF EXISTS raw_received;
CREATE INDEX IF NOT EXISTS raw_expiry ON raw (received_time, device, seq);
CREATE INDEX IF NOT EXISTS raw_window ON raw (device, device_time);
CREATE TABLE IF NOT EXISTS streams (device TEXT PRIMARY KEY, state TEXT, filter BLOB);
CREATE TABLE IF NOT EXISTS days (subject TEXT, day TEXT, energy REAL, seconds REAL, eav_at REAL, elv_at REAL,
    hands TEXT, PRIMARY KEY (subject, day));
CREATE TABLE IF NOT EXISTS sessions (device TEXT PRIMARY KEY, session TEXT);
CREATE TABLE IF NOT EXISTS activities (id TEXT PRIMARY KEY, subject TEXT, day TEXT, state TEXT);
CREATE TABLE IF NOT EXISTS events (id INTEGER PRIMARY KEY AUTOINCREMENT, kind TEXT, time REAL, subject TEXT,
    source TEXT, data TEXT, received REAL);
CREATE TABLE IF NOT EXISTS corrections (subject TEXT, position TEXT, fit TEXT, PRIMARY KEY (subject, position));
CREATE TABLE IF NOT EXISTS malformed (device TEXT PRIMARY KEY, count INTEGER, last_reason TEXT, last_received REAL);
"""


WINDOW_LOOKBACK_S = MAX_BATCH_S + 1.0
"""Seconds before a window's start where a batch reaching into the window may begin: batches hold at most
``MAX_BATCH_S`` of samples (the bus refuses longer ones, ``HavMonitor.ingest_many`` too), plus rounding."""
RAW_WINDOW_SQL = ("SELECT device, seq, device_time, received_time, fs, full_scale, n, samples, scale FROM raw "
                  "WHERE device = :device AND device_time > :start - :lookback AND device_time < :end "
                  "AND device_time + n / fs > :start ORDER BY seq")
"""A device's batches with samples in device time [start, end): a range on the ``raw_window`` index (device,
device_time) bounded on both sides, never a scan of the device's whole raw history."""


class ExposureStore:
    """The monitor's SQLite file (WAL, synchronous=NORMAL: a committed ingest survives a process crash)."""

    def __init__(self, path: Path | None):
        """``path`` None keeps the store in memory (a throw-away monitor, e.g. analysing a file)."""
        self.path = Path(path) if path is not None else None
        if self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        self._db = sqlite3.connect(self.path or ":memory:", check_same_thread=False, isolation_level=None)
        self._db.execute(f"PRAGMA page_size={PAGE_SIZE}")  # a new file only; an existing one keeps its own
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute("PRAGMA synchronous=NORMAL")
        self._db.executescript(_SCHEMA)
        if "scale" not in {row[1] for row in self._db.execute("PRAGMA table_info(raw)")}:  # a store from 0.1
            self._db.execute("ALTER TABLE raw ADD COLUMN scale REAL")
        self.commits, self.commit_s = 0, 0.0
        """Transactions committed, and the thread CPU seconds spent inside them (``bench hav`` reads both)."""

    @contextmanager
    def transaction(self) -> Iterator[ExposureStore]:
        """All writes inside commit together or not at all."""
        start = time.thread_time()
        self._db.execute("BEGIN")
        try:
            yield self
        except BaseException:
            self._db.execute("ROLLBACK")
            raise
        self._db.execute("COMMIT")
        self.commits += 1
        self.commit_s += time.thread_time() - start

    # raw batches ---------------------------------------------------------------------------------------
    def save_raw(self, batches: Iterable[AccelBatch]) -> None:
        """Samples as they came: int16 counts (half the bytes) when the batch has a count ``scale``, else float32."""
        self._db.executemany("INSERT OR IGNORE INTO raw VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)", [
            (b.device, b.seq, b.device_time, b.received_time, b.fs, b.full_scale, b.xyz.shape[0], *_packed(b))
            for b in batches])

    def raw_batches(self, device: str, from_seq: int) -> list[AccelBatch]:
        rows = self._db.execute("SELECT device, seq, device_time, received_time, fs, full_scale, n, samples, scale "
                                "FROM raw WHERE device = ? AND seq >= ? ORDER BY seq", (device, from_seq)).fetchall()
        return [AccelBatch(d, s, t, fs, _xyz(blob, n, scale), fsc, rt, scale)
                for d, s, t, rt, fs, fsc, n, blob, scale in rows]

    def drop_raw(self, streams: Iterable[tuple[str, int]], received_by: float) -> None:
        """Delete each (device, next seq) stream's processed batches (seq < next seq) received at or before
        ``received_by``.

        The candidates come from the covering index on (received_time, device, seq): only rows past retention
        are visited, never a stream's whole history. Searching by (device, seq < next seq) instead read every
        stored row of the stream on every commit (each one a page read): quadratic in the shift's length."""
        before = dict(streams)
        expired = self._db.execute("SELECT device, seq FROM raw INDEXED BY raw_expiry WHERE received_time <= ?",
                                   (received_by,)).fetchall()
        self._db.executemany("DELETE FROM raw WHERE device = ? AND seq = ?",
                             [(device, seq) for device, seq in expired if seq < before.get(device, seq)])

    def raw_seqs(self, device: str) -> list[int]:
        return [row[0] for row in self._db.execute("SELECT seq FROM raw WHERE device = ? ORDER BY seq", (device,))]

    def raw_count(self) -> int:
        return self._db.execute("SELECT COUNT(*) FROM raw").fetchone()[0]

    def raw_window(self, device: str, start: float, end: float) -> list[AccelBatch]:
        """The device's kept batches with samples in device time [start, end), in seq order (the dashboard's
        raw sensor window; what retention already dropped is not there)."""
        rows = self._db.execute(RAW_WINDOW_SQL, {"device": device, "start": start, "end": end,
                                                 "lookback": WINDOW_LOOKBACK_S}).fetchall()
        return [AccelBatch(d, s, t, fs, _xyz(blob, n, scale), fsc, rt, scale)
                for d, s, t, rt, fs, fsc, n, blob, scale in rows]

    # JSON state rows -----------------------------------------------------------------------------------
    def save_streams(self, states: Iterable[tuple[str, Any, bytes]]) -> None:
        """(device, JSON-able state, filter-state blob) rows."""
        self._db.executemany("INSERT INTO streams VALUES (?, ?, ?) ON CONFLICT (device) DO UPDATE SET "
                             "state = excluded.state, filter = excluded.filter",
                             [(device, json.dumps(state), blob) for device, state, blob in states])

    def streams(self) -> dict[str, tuple[Any, bytes]]:
        rows = self._db.execute("SELECT device, state, filter FROM streams")
        return {device: (json.loads(state), blob) for device, state, blob in rows}

    def save_days(self, rows: Iterable[tuple[str, str, Any]]) -> None:
        """(subject, day, DayState) rows: the day's energy (m^2/s^3) and trigger seconds of the greater hand,
        EAV/ELV times, and every hand's figures."""
        self._db.executemany("INSERT INTO days VALUES (?, ?, ?, ?, ?, ?, ?) ON CONFLICT (subject, day) DO UPDATE SET "
                             "energy = excluded.energy, seconds = excluded.seconds, eav_at = excluded.eav_at, "
                             "elv_at = excluded.elv_at, hands = excluded.hands", [
            (subject, day, state.energy, state.seconds, state.eav_at, state.elv_at, _hands_json(state.hands))
            for subject, day, state in rows])

    def days(self) -> dict[tuple[str, str], tuple[dict, float | None, float | None]]:
        """(subject, day) -> (hands, EAV time, ELV time)."""
        rows = self._db.execute("SELECT subject, day, energy, seconds, hands, eav_at, elv_at FROM days")
        return {(subject, day): (json.loads(hands) if hands else {"": [energy, seconds]}, eav, elv)
                for subject, day, energy, seconds, hands, eav, elv in rows}

    def save_session(self, device: str, session: dict[str, Any]) -> None:
        self._db.execute("INSERT OR REPLACE INTO sessions VALUES (?, ?)", (device, json.dumps(session)))

    def sessions(self) -> dict[str, dict[str, Any]]:
        return {d: json.loads(s) for d, s in self._db.execute("SELECT device, session FROM sessions")}

    def save_activities(self, rows: Iterable[tuple[str, str, str, dict[str, Any]]]) -> None:
        """(activity id, subject, day, state) rows, inserted or replaced."""
        self._db.executemany("INSERT OR REPLACE INTO activities VALUES (?, ?, ?, ?)",
                             [(i, subject, day, json.dumps(state)) for i, subject, day, state in rows])

    def activities(self, subject: str | None = None) -> list[dict[str, Any]]:
        rows = self._db.execute("SELECT id, subject, day, state FROM activities ORDER BY id")
        return [{"id": i, "subject": s, "day": d, **json.loads(v)} for i, s, d, v in rows
                if subject is None or s == subject]

    def save_correction(self, subject: str, position: str, fit_json: str) -> None:
        self._db.execute("INSERT OR REPLACE INTO corrections VALUES (?, ?, ?)", (subject, position, fit_json))

    def corrections(self) -> list[str]:
        return [row[0] for row in self._db.execute("SELECT fit FROM corrections")]

    def save_malformed(self, rows: Iterable[tuple[str, int, str, float | None]]) -> None:
        """(device, count, last reason, last received) of refused messages."""
        self._db.executemany("INSERT OR REPLACE INTO malformed VALUES (?, ?, ?, ?)", list(rows))

    def malformed(self) -> dict[str, tuple[int, str, float | None]]:
        return {d: (c, r, t) for d, c, r, t in self._db.execute("SELECT * FROM malformed")}

    # events --------------------------------------------------------------------------------------------
    def add_events(self, events: Iterable[Event]) -> None:
        self._db.executemany("INSERT INTO events (kind, time, subject, source, data, received) VALUES (?,?,?,?,?,?)",
                             [(e.kind, e.time, e.subject, e.source, json.dumps(e.data, default=float), e.received)
                              for e in events])

    def events(self, kind: str | None = None) -> list[Event]:
        rows = self._db.execute("SELECT kind, time, subject, source, data, received FROM events ORDER BY id")
        return [Event(k, t, s, src, json.loads(d), r) for k, t, s, src, d, r in rows if kind in (None, k)]

    def close(self) -> None:
        self._db.close()


def _packed(batch: AccelBatch) -> tuple[bytes, float | None]:
    """(samples, count scale): int16 counts when xyz is exactly counts x float32(scale) (as decoded from an int16
    payload; dividing back errs by under 0.01 count), else float32 and no scale."""
    if batch.scale is not None:
        scale = np.float32(batch.scale)
        with np.errstate(all="ignore"):
            counts = np.rint(batch.xyz / scale)
            if np.array_equal(np.clip(counts, -32768, 32767).astype(np.float32) * scale, batch.xyz):
                return counts.astype("<i2").tobytes(), batch.scale
    return np.ascontiguousarray(batch.xyz, dtype=np.float32).tobytes(), None


def _xyz(blob: bytes, n: int, scale: float | None) -> np.ndarray:
    if scale is None:
        return np.frombuffer(blob, np.float32).reshape(n, 3)
    return np.frombuffer(blob, "<i2").reshape(n, 3).astype(np.float32) * np.float32(scale)


def _hands_json(hands: dict[str, list[float]]) -> str | None:
    """Per-hand figures as JSON; None for the usual single unnamed hand (the energy/seconds columns hold it)."""
    return None if len(hands) == 1 and "" in hands else json.dumps(hands)
