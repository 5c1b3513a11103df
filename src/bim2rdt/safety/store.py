"""Exposure state in a database, through SQLAlchemy Core (the twin's URL handling, :mod:`bim2rdt.sqlstore`): an
SQLite file by default (WAL, one transaction per ingest, so a restart loses nothing), PostgreSQL by URL when
several monitor processes share one store.

What is kept: raw batches (out-of-order ones until they are processed, the rest by the raw retention rule of
:mod:`bim2rdt.safety.retention`), each stream's ordering, filter and activity state, each worker-day's accumulated
weighted energy and the times EAV and ELV were reached, activities, events, fitted mounting corrections, the
ledger of applied batches (``applied``: a batch is applied at most once, keyed on (device, boot, seq)) and the
outbox of events for durable sinks. Workers appear only as pseudonyms; the identity map lives apart (see
:mod:`bim2rdt.safety.privacy`). The schema is versioned: :data:`MIGRATIONS` bring an older store up to date.
"""

from __future__ import annotations

import json
import re
import threading
import time
import zlib
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager, nullcontext
from pathlib import Path
from typing import Any

import numpy as np
import sqlalchemy as sa
from sqlalchemy.engine import Connection
from sqlalchemy.exc import SQLAlchemyError

from bim2rdt import sqlstore
from bim2rdt.bus import Event
from bim2rdt.bus import MAX_BATCH_S, AccelBatch
from bim2rdt.safety.errors import AlreadyApplied, StoreError
from bim2rdt.safety.statecodec import decode_state

PAGE_SIZE = 16384
"""Bytes per SQLite page. A 0.5 s int16 batch at 5 kHz is 15 kB: on 4 kB pages it spans an overflow chain of
four pages, each written to the WAL and again at the checkpoint; 16 kB pages cut the commit cost per batch from
58 to 38 us (2 wearables x 15 min, median of 3 interleaved runs) without making small-row updates heavy."""
SQLITE_PRAGMAS = (f"page_size={PAGE_SIZE}", "synchronous=NORMAL", "journal_size_limit=16777216", "cache_size=-32768")
"""A committed ingest survives a process crash (WAL, synchronous=NORMAL); page_size applies to a new file only;
the WAL file is cut back to 16 MB after a checkpoint (it would keep its largest size)."""
LEDGER_KEEP_S = 3 * 3600.0
"""Seconds an applied batch's key stays in the ledger: longer than any redelivery (an MQTT session queues for an
hour by default; a JetStream redelivery comes within ack_wait x max_deliver); older duplicates are still found by
each stream's own memory of the times it took."""
LEDGER_PRUNE_EVERY_S = 600.0
"""The ledger is pruned at most this often (seconds of the monitor's clock): a scan of its keys (it has no index
on time, so each commit writes one b-tree only)."""
RAW_PLAIN, RAW_ZLIB = 0, 1
"""Codecs of a raw blob: as packed, or the packed samples' low bytes as they are and their high bytes through zlib
(level 1)."""

metadata = sa.MetaData()
_ID = sa.BigInteger().with_variant(sa.Integer(), "sqlite")
raw_table = sa.Table(
    "raw", metadata,
    sa.Column("device", sa.Text, primary_key=True), sa.Column("seq", sa.BigInteger, primary_key=True),
    sa.Column("device_time", sa.Double), sa.Column("received_time", sa.Double), sa.Column("fs", sa.Double),
    sa.Column("full_scale", sa.Double), sa.Column("n", sa.Integer), sa.Column("samples", sa.LargeBinary),
    sa.Column("scale", sa.Double), sa.Column("codec", sa.SmallInteger, nullable=False, server_default="0"),
    sa.Column("kept", sa.SmallInteger, nullable=False, server_default="0"),
    sa.Index("raw_expiry", "received_time", "device", "seq"), sa.Index("raw_window", "device", "device_time"))
streams_table = sa.Table("streams", metadata, sa.Column("device", sa.Text, primary_key=True),
                         sa.Column("state", sa.Text), sa.Column("filter", sa.LargeBinary))
days_table = sa.Table(
    "days", metadata, sa.Column("subject", sa.Text, primary_key=True), sa.Column("day", sa.Text, primary_key=True),
    sa.Column("energy", sa.Double), sa.Column("seconds", sa.Double), sa.Column("eav_at", sa.Double),
    sa.Column("elv_at", sa.Double), sa.Column("hands", sa.Text))
day_parts_table = sa.Table(
    "day_parts", metadata, sa.Column("subject", sa.Text, primary_key=True), sa.Column("day", sa.Text, primary_key=True),
    sa.Column("part", sa.Text, primary_key=True), sa.Column("eav_at", sa.Double), sa.Column("elv_at", sa.Double),
    sa.Column("hands", sa.Text, nullable=False))
"""Contributions to a worker-day by the monitors of a partitioned store (the NATS path), one row per partition
(``part`` 'K/N'): a worker whose devices fall into two partitions has two rows, and the day is their sum. The
single-process monitor's contribution is the ``days`` row (part '')."""
sessions_table = sa.Table("sessions", metadata, sa.Column("device", sa.Text, primary_key=True),
                          sa.Column("session", sa.Text))
activities_table = sa.Table("activities", metadata, sa.Column("id", sa.Text, primary_key=True),
                            sa.Column("subject", sa.Text), sa.Column("day", sa.Text), sa.Column("state", sa.Text))
events_table = sa.Table(
    "events", metadata, sa.Column("id", _ID, primary_key=True, autoincrement=True), sa.Column("kind", sa.Text),
    sa.Column("time", sa.Double), sa.Column("subject", sa.Text), sa.Column("source", sa.Text),
    sa.Column("data", sa.Text), sa.Column("received", sa.Double), sqlite_autoincrement=True)
corrections_table = sa.Table(
    "corrections", metadata, sa.Column("subject", sa.Text, primary_key=True),
    sa.Column("position", sa.Text, primary_key=True), sa.Column("fit", sa.Text))
malformed_table = sa.Table(
    "malformed", metadata, sa.Column("device", sa.Text, primary_key=True), sa.Column("count", sa.Integer),
    sa.Column("last_reason", sa.Text), sa.Column("last_received", sa.Double))
applied_table = sa.Table(
    "applied", metadata, sa.Column("device", sa.Text, primary_key=True), sa.Column("boot", sa.Text, primary_key=True),
    sa.Column("seq", sa.BigInteger, primary_key=True), sa.Column("received_time", sa.Double, nullable=False),
    sqlite_with_rowid=False)
outbox_table = sa.Table(
    "outbox", metadata, sa.Column("id", _ID, primary_key=True, autoincrement=True),
    sa.Column("sink", sa.Text, nullable=False), sa.Column("event", sa.Text, nullable=False),
    sa.Index("outbox_sink", "sink", "id"), sqlite_autoincrement=True)
keep_table = sa.Table(
    "raw_keep", metadata, sa.Column("device", sa.Text, nullable=False),
    sa.Column("window_start", sa.Double, nullable=False), sa.Column("window_end", sa.Double, nullable=False),
    sa.Column("keep_until", sa.Double, nullable=False), sa.Index("raw_keep_until", "keep_until"))
version_table = sa.Table("hav_schema", metadata, sa.Column("version", sa.Integer, nullable=False))


def _add_column(table: str, column: str, ddl: str) -> Callable[[Connection], None]:
    def step(conn: Connection) -> None:
        if column not in {c["name"] for c in sa.inspect(conn).get_columns(table)}:
            conn.exec_driver_sql(f"ALTER TABLE {table} ADD COLUMN {column} {ddl}")
    return step


def _drop_raw_received(conn: Connection) -> None:
    conn.exec_driver_sql("DROP INDEX IF EXISTS raw_received")  # the expiry index before raw_expiry


MIGRATIONS: list[tuple[int, str, Callable[[Connection], None]]] = [
    (1, "raw samples as int16 counts with a scale (stores from 0.1)", _add_column("raw", "scale", "REAL")),
    (2, "the expiry index raw_received replaced by the covering raw_expiry", _drop_raw_received),
    (3, "compressed raw blobs", _add_column("raw", "codec", "SMALLINT NOT NULL DEFAULT 0")),
    (4, "raw batches kept around events", _add_column("raw", "kept", "SMALLINT NOT NULL DEFAULT 0")),
    (5, "worker-days summed over the partitions' contributions (day_parts)", lambda conn: None),
]
"""(version, what, step) in order: each step runs once, in its own transaction, on a store older than it; a new
store is created at the last version. Tables and indexes a step does not name are created as they are defined."""
SCHEMA_VERSION = MIGRATIONS[-1][0]

WINDOW_LOOKBACK_S = MAX_BATCH_S + 1.0
"""Seconds before a window's start where a batch reaching into the window may begin: batches hold at most
``MAX_BATCH_S`` of samples (the bus refuses longer ones, ``HavMonitor.ingest_many`` too), plus rounding."""
_RAW_COLUMNS = "device, seq, device_time, received_time, fs, full_scale, n, samples, scale, codec"
RAW_WINDOW_SQL = (f"SELECT {_RAW_COLUMNS} FROM raw "
                  "WHERE device = :device AND device_time > :start - :lookback AND device_time < :end "
                  "AND device_time + n / fs > :start ORDER BY seq")
"""A device's batches with samples in device time [start, end): a range on the ``raw_window`` index (device,
device_time) bounded on both sides, never a scan of the device's whole raw history."""


class ExposureStore:
    """The monitor's store at a SQLAlchemy URL; one writer connection (the monitor's, under its lock), pooled
    connections for readers and the outbox."""

    def __init__(self, location: Path | str | None, busy_timeout_s: float = sqlstore.SQLITE_BUSY_TIMEOUT_S):
        """``location``: a SQLAlchemy URL (``sqlite:///var/hav/hav.sqlite``, ``postgresql+psycopg://...``), a
        path of an SQLite file, or None for a throw-away store in memory (``hav analyze``). StoreError if it
        cannot be opened."""
        if location is None or isinstance(location, Path):
            url_text = f"sqlite:///{location}" if location is not None else "sqlite://"
        else:
            url_text = location
        self.url = sqlstore.parse_url(url_text, StoreError, "the exposure store", "sqlite:///var/hav/hav.sqlite")
        self.label = sqlstore.label(self.url)
        self.path = Path(self.url.database) if self.url.get_backend_name() == "sqlite" and not \
            sqlstore.is_memory(self.url) else None
        self.dialect = self.url.get_backend_name()
        self.engine = sqlstore.make_engine(self.url, StoreError, "the exposure store", SQLITE_PRAGMAS, busy_timeout_s)
        self._guard = threading.RLock() if sqlstore.is_memory(self.url) else nullcontext()
        """An in-memory store is one connection shared by all threads: one of them uses it at a time."""
        self._dbapi = self.engine.dialect.loaded_dbapi
        self._sql: dict[str, str] = {}
        self._cursor = None
        with self._errors("cannot open"):
            self._writer = self.engine.connect()
            with sqlstore.schema_lock(self._writer):
                migrate(self._writer)
        self._owner: int | None = None
        self._leases: set[str] = set()
        self._lease_conn: Connection | None = None
        self._pruned_at = -float("inf")
        self.commits, self.commit_s = 0, 0.0
        """Transactions committed, and the thread CPU seconds spent inside them (``bench hav`` reads both)."""

    @classmethod
    def for_folder(cls, folder: Path | None, url: str | None = None) -> ExposureStore:
        """The store at ``url``, else ``folder/hav.sqlite``, else in memory."""
        return cls(url if url else (Path(folder) / "hav.sqlite" if folder is not None else None))

    @contextmanager
    def transaction(self) -> Iterator[ExposureStore]:
        """All writes inside commit together or not at all (the monitor's writer connection)."""
        start = time.thread_time()
        with self._guard, self._errors("could not write"):
            raw = self._writer.connection.dbapi_connection
            self._cursor, self._owner = raw.cursor(), threading.get_ident()
            try:
                if self.dialect == "sqlite":
                    self._cursor.execute("BEGIN")
                yield self
            except BaseException:
                raw.rollback()
                raise
            else:
                raw.commit()
            finally:
                self._cursor.close()
                self._cursor = None
        self.commits += 1
        self.commit_s += time.thread_time() - start

    # raw batches ---------------------------------------------------------------------------------------
    def save_raw(self, batches: Iterable[AccelBatch], compress: bool = False) -> int:
        """Samples as they came: int16 counts (half the bytes) when the batch has a count ``scale``, else float32;
        with ``compress``, zlib over the samples' byte planes (lossless). Returns the bytes of samples written."""
        rows = [{"device": b.device, "seq": b.seq, "device_time": b.device_time, "received_time": b.received_time,
                 "fs": b.fs, "full_scale": b.full_scale, "n": b.xyz.shape[0], **_packed(b, compress)}
                for b in batches]
        if rows:
            self._exec(_insert_sql(raw_table, rows[0], conflict=" ON CONFLICT DO NOTHING"), rows)
        return sum(len(row["samples"]) for row in rows)

    def raw_batches(self, device: str, from_seq: int) -> list[AccelBatch]:
        t = raw_table.c
        query = sa.select(*_raw_columns()).where(t.device == device, t.seq >= from_seq).order_by(t.seq)
        return [_batch(row) for row in self._read(query)]

    def drop_raw(self, streams: Iterable[tuple[str, int]], received_by: float) -> None:
        """Delete each (device, next seq) stream's processed batches (seq < next seq) received at or before
        ``received_by``.

        The candidates come from the covering index on (received_time, device, seq): only rows past retention
        are visited, never a stream's whole history. Searching by (device, seq < next seq) instead read every
        stored row of the stream on every commit (each one a page read): quadratic in the shift's length."""
        before = dict(streams)
        expired = self._exec(_expired_sql(self.dialect), {"by": received_by}).fetchall()
        gone = [{"d": device, "s": seq} for device, seq in expired if seq < before.get(device, seq)]
        if gone:
            self._exec("DELETE FROM raw WHERE device = :d AND seq = :s", gone)

    def unkept_between(self, device: str, low: float, cut: float) -> list[tuple[int, float, float, int]]:
        """(seq, start, end device time, blob bytes) of the device's unmarked batches starting in device time
        [low, cut)."""
        rows = self._exec("SELECT seq, device_time, device_time + n / fs, LENGTH(samples) FROM raw WHERE "
                          "device = :d AND device_time >= :low AND device_time < :cut AND kept = 0",
                          {"d": device, "low": low, "cut": cut}).fetchall()
        return [(int(seq), start, end, int(size)) for seq, start, end, size in rows]

    def keep_raw(self, rows: Iterable[tuple[str, int]], compress: bool) -> int:
        """Mark these (device, seq) batches kept around an event; with ``compress``, their samples compressed.
        Returns the bytes saved."""
        rows = [{"d": d, "s": s} for d, s in rows]
        if not rows:
            return 0
        if not compress:
            self._exec("UPDATE raw SET kept = 1 WHERE device = :d AND seq = :s", rows)
            return 0
        found = [self._exec("SELECT samples, scale, codec FROM raw WHERE device = :d AND seq = :s", row).fetchone()
                 for row in rows]
        rows = [{**row, "b": _compressed(bytes(blob), scale, codec), "n": len(blob)}
                for row, (blob, scale, codec) in zip(rows, found)]
        self._exec(f"UPDATE raw SET kept = 1, codec = {RAW_ZLIB}, samples = :b WHERE device = :d AND seq = :s",
                   [{k: row[k] for k in ("b", "d", "s")} for row in rows])
        return sum(row["n"] - len(row["b"]) for row in rows)

    def delete_raw(self, rows: Iterable[tuple[str, int]]) -> None:
        rows = [{"d": d, "s": s} for d, s in rows]
        if rows:
            self._exec("DELETE FROM raw WHERE device = :d AND seq = :s", rows)

    def raw_bytes(self) -> int:
        """Bytes of raw samples stored (blobs only; inside a transaction)."""
        return int(self._exec("SELECT COALESCE(SUM(LENGTH(samples)), 0) FROM raw", {}).fetchone()[0])

    def oldest_raw(self, limit: int = 2000) -> list[tuple[str, int, int]]:
        """(device, seq, blob bytes) of the ``limit`` raw batches received first (inside a transaction)."""
        rows = self._exec("SELECT device, seq, LENGTH(samples) FROM raw ORDER BY received_time LIMIT :n",
                          {"n": limit}).fetchall()
        return [(d, int(s), int(n)) for d, s, n in rows]

    def raw_seqs(self, device: str) -> list[int]:
        t = raw_table.c
        return [row[0] for row in self._read(sa.select(t.seq).where(t.device == device).order_by(t.seq))]

    def raw_count(self) -> int:
        return int(self._read(sa.select(sa.func.count()).select_from(raw_table)).scalar_one())

    def raw_window(self, device: str, start: float, end: float) -> list[AccelBatch]:
        """The device's kept batches with samples in device time [start, end), in seq order (the dashboard's
        raw sensor window; what retention already dropped is not there)."""
        rows = self._read(sa.text(RAW_WINDOW_SQL), {"device": device, "start": start, "end": end,
                                                    "lookback": WINDOW_LOOKBACK_S})
        return [_batch(row) for row in rows]

    def last_raw(self, device: str) -> AccelBatch | None:
        """The device's kept batch with the highest seq (None when none is kept)."""
        t = raw_table.c
        row = self._read(sa.select(*_raw_columns()).where(t.device == device).order_by(t.seq.desc()).limit(1)).first()
        return _batch(row) if row is not None else None

    # windows of raw data kept around events ------------------------------------------------------------
    def add_keep_windows(self, rows: Iterable[tuple[str, float, float, float]]) -> None:
        """(device, start, end device time, keep until (receive clock)) windows whose raw batches are kept."""
        rows = [{"device": d, "window_start": s, "window_end": e, "keep_until": u} for d, s, e, u in rows]
        if rows:
            self._exec(_insert_sql(keep_table, rows[0]), rows)

    def keep_windows(self) -> list[tuple[str, float, float, float]]:
        t = keep_table.c
        return [tuple(row) for row in self._read(sa.select(t.device, t.window_start, t.window_end, t.keep_until))]

    def drop_keep_windows(self, received_by: float) -> None:
        self._exec("DELETE FROM raw_keep WHERE keep_until <= :by", {"by": received_by})

    # the ledger of applied batches ---------------------------------------------------------------------
    def mark_applied(self, keys: Iterable[tuple[str, str, int, float]], now: float) -> None:
        """Record (device, boot, seq, received time) of batches this commit applies. AlreadyApplied (the
        transaction rolls back) if one was applied before: by another process, or by this one before it restored."""
        rows = keys if isinstance(keys, list) else list(keys)
        if rows:
            try:
                self._exec_rows(_APPLIED_SQL, rows)
            except self._dbapi.IntegrityError:
                raise AlreadyApplied("a batch of this commit was applied before (another monitor process, or a "
                                     "redelivery): reload and retry") from None
        if now - self._pruned_at >= LEDGER_PRUNE_EVERY_S:
            self._pruned_at = now
            self._exec("DELETE FROM applied WHERE received_time < :by", {"by": now - LEDGER_KEEP_S})

    def applied_count(self) -> int:
        return int(self._read(sa.select(sa.func.count()).select_from(applied_table)).scalar_one())

    # JSON state rows -----------------------------------------------------------------------------------
    def save_streams(self, states: Iterable[tuple[str, Any, bytes]]) -> None:
        """(device, state, filter-state blob) rows: the state as the text of
        :func:`~bim2rdt.safety.statecodec.encode_state`, or a JSON-able value (written as ``json.dumps`` would)."""
        rows = [(device, state if state.__class__ is str else _dumps(state), blob) for device, state, blob in states]
        if rows:
            self._exec_rows(_STREAMS_SQL, rows)

    def streams(self) -> dict[str, tuple[Any, bytes]]:
        """{device: (state, filter-state blob)}, the state as ``json.loads`` gives its JSON form (packed or not)."""
        rows = self._read(sa.select(streams_table))
        return {device: (decode_state(state), bytes(blob)) for device, state, blob in rows}

    def save_days(self, rows: Iterable[tuple[str, str, Any]]) -> None:
        """(subject, day, DayState) rows: the day's energy (m^2/s^3) and trigger seconds of the greater hand,
        EAV/ELV times, and every hand's figures."""
        rows = [(subject, day, state.energy, state.seconds, state.eav_at, state.elv_at, _hands_json(state.hands))
                for subject, day, state in rows]
        if rows:
            self._exec_rows(_DAYS_SQL, rows)

    def save_day_parts(self, part: str, rows: Iterable[tuple[str, str, Any]]) -> None:
        """(subject, day, DayState) rows: partition ``part``'s contributions to worker-days (see ``day_parts``)."""
        self._upsert(day_parts_table, [{"subject": subject, "day": day, "part": part, "eav_at": state.eav_at,
                                        "elv_at": state.elv_at, "hands": json.dumps(state.hands)}
                                       for subject, day, state in rows], ("subject", "day", "part"))

    def days(self, part: str | None = None, exclude: str | None = None, since_day: str = ""
             ) -> dict[tuple[str, str], tuple[dict, float | None, float | None]]:
        """(subject, day) -> (hands, EAV time, ELV time), summed over the contributions (the ``days`` row, part '',
        and the partitions' ``day_parts`` rows): of ``part`` only, or of every part but ``exclude``; days from
        ``since_day`` ('YYYY-MM-DD') on. Per hand energy and seconds add up; EAV/ELV times are the earliest."""
        t, p = days_table.c, day_parts_table.c
        found: dict[tuple[str, str], tuple[dict, float | None, float | None]] = {}
        if part in (None, "") and exclude != "":
            for subject, day, energy, seconds, hands, eav, elv in self._read(
                    sa.select(t.subject, t.day, t.energy, t.seconds, t.hands, t.eav_at, t.elv_at)
                    .where(t.day >= since_day)):
                _add_day(found, (subject, day), json.loads(hands) if hands else {"": [energy, seconds]}, eav, elv)
        if part != "":
            query = sa.select(p.subject, p.day, p.hands, p.eav_at, p.elv_at).where(p.day >= since_day)
            query = query.where(p.part == part) if part is not None else query
            query = query.where(p.part != exclude) if exclude is not None else query
            for subject, day, hands, eav, elv in self._read(query):
                _add_day(found, (subject, day), json.loads(hands), eav, elv)
        return found

    def save_session(self, device: str, session: dict[str, Any]) -> None:
        self._upsert(sessions_table, [{"device": device, "session": json.dumps(session)}], ("device",))

    def sessions(self) -> dict[str, dict[str, Any]]:
        return {d: json.loads(s) for d, s in self._read(sa.select(sessions_table))}

    def save_activities(self, rows: Iterable[tuple[str, str, str, dict[str, Any]]]) -> None:
        """(activity id, subject, day, state) rows, inserted or replaced (an activity that already ended within
        the commit has no open row: id None, skipped)."""
        self._upsert(activities_table, [{"id": i, "subject": subject, "day": day, "state": json.dumps(state)}
                                        for i, subject, day, state in rows if i is not None], ("id",))

    def activities(self, subject: str | None = None) -> list[dict[str, Any]]:
        rows = self._read(sa.select(activities_table).order_by(activities_table.c.id))
        return [{"id": i, "subject": s, "day": d, **json.loads(v)} for i, s, d, v in rows
                if subject is None or s == subject]

    def save_correction(self, subject: str, position: str, fit_json: str) -> None:
        self._upsert(corrections_table, [{"subject": subject, "position": position, "fit": fit_json}],
                     ("subject", "position"))

    def corrections(self) -> list[str]:
        return [row[0] for row in self._read(sa.select(corrections_table.c.fit))]

    def save_malformed(self, rows: Iterable[tuple[str, int, str, float | None]]) -> None:
        """(device, count, last reason, last received) of refused messages."""
        self._upsert(malformed_table, [{"device": d, "count": c, "last_reason": r, "last_received": t}
                                       for d, c, r, t in rows], ("device",))

    def malformed(self) -> dict[str, tuple[int, str, float | None]]:
        return {d: (c, r, t) for d, c, r, t in self._read(sa.select(malformed_table))}

    # events and the outbox -----------------------------------------------------------------------------
    def add_events(self, events: Iterable[Event], outbox: Iterable[str] = ()) -> None:
        """Append the events; with ``outbox``, also queue them (in order) for each of those durable sinks."""
        events, sinks = list(events), list(outbox)
        if not events:
            return
        self._exec(_insert_sql(events_table, _EVENT_ROW), [
            {"kind": e.kind, "time": e.time, "subject": e.subject, "source": e.source,
             "data": json.dumps(e.data, default=float), "received": e.received} for e in events])
        if sinks:
            payloads = [e.to_json().decode() for e in events]
            self._exec(_insert_sql(outbox_table, _OUTBOX_ROW), [{"sink": sink, "event": p} for sink in sinks
                                                                 for p in payloads])

    def events(self, kind: str | None = None, since: float | None = None) -> list[Event]:
        """The events in commit order, of ``kind`` (default all), that happened after ``since`` (UTC s)."""
        t = events_table.c
        query = sa.select(t.kind, t.time, t.subject, t.source, t.data, t.received).order_by(t.id)
        if kind is not None:
            query = query.where(t.kind == kind)
        if since is not None:
            query = query.where(t.time > since)
        return [Event(k, tm, s, src, json.loads(d), r) for k, tm, s, src, d, r in self._read(query)]

    def outbox(self, sink: str, limit: int = 500) -> list[tuple[int, Event]]:
        """The oldest ``limit`` (id, event) waiting for ``sink``, in the order they were committed."""
        t = outbox_table.c
        rows = self._read(sa.select(t.id, t.event).where(t.sink == sink).order_by(t.id).limit(limit))
        return [(int(i), Event.from_json(text)) for i, text in rows]

    def outbox_done(self, ids: Iterable[int]) -> None:
        """Remove delivered outbox rows (their own short transaction, never the monitor's)."""
        ids = list(ids)
        if ids:
            with self._guard, self._errors("could not write"), sqlstore.write_connection(self.engine) as conn, \
                    conn.begin():
                conn.execute(outbox_table.delete().where(outbox_table.c.id.in_(ids)))

    def outbox_lease(self, sink: str) -> bool:
        """Whether this process delivers ``sink``'s queue: always on SQLite (one process owns the file); on
        PostgreSQL the one holding a session advisory lock per sink (released when its connection ends, so a
        standby process takes over after a crash)."""
        if self.dialect != "postgresql":
            return True
        if sink in self._leases:
            return True
        with self._errors("could not lease the outbox of"):
            if self._lease_conn is None:
                self._lease_conn = self.engine.connect().execution_options(isolation_level="AUTOCOMMIT")
            key = zlib.crc32(f"bim2rdt-hav-outbox:{sink}".encode())
            if self._lease_conn.execute(sa.text("SELECT pg_try_advisory_lock(:k)"), {"k": key}).scalar():
                self._leases.add(sink)
        return sink in self._leases

    def outbox_count(self, sink: str | None = None) -> int:
        query = sa.select(sa.func.count()).select_from(outbox_table)
        if sink is not None:
            query = query.where(outbox_table.c.sink == sink)
        return int(self._read(query).scalar_one())

    def size_bytes(self) -> int:
        """Bytes the store takes on disk (an SQLite file with its WAL; the database's size on PostgreSQL)."""
        if self.path is not None:
            return sum(p.stat().st_size for p in self.path.parent.glob(self.path.name + "*") if p.is_file())
        if self.dialect == "postgresql":
            return int(self._read(sa.text("SELECT pg_database_size(current_database())")).scalar_one())
        return 0

    def close(self) -> None:
        with self._guard:
            if self._lease_conn is not None:
                self._lease_conn.close()
            self._writer.close()
            self.engine.dispose()

    # internals -----------------------------------------------------------------------------------------
    def _exec(self, sql: str, params: dict | list[dict]):
        """Run a write (``:name`` parameters; a list runs it once per row) inside the open transaction, straight
        on the driver's cursor: the commit path's statements are fixed text, so SQLAlchemy's per-statement work
        would be its largest cost."""
        if self._cursor is None:
            raise StoreError("the exposure store writes only inside transaction()")
        text = self._sql.get(sql)
        if text is None:
            text = self._sql[sql] = re.sub(r":(\w+)", r"%(\1)s", sql) if self.dialect == "postgresql" else sql
        if isinstance(params, list):
            self._cursor.executemany(text, params)
        else:
            self._cursor.execute(text, params)
        return self._cursor

    def _exec_rows(self, sql: str, rows: list[tuple]) -> None:
        """Run a write once per row, its parameters positional (``?``, rows as tuples in the statement's column
        order), inside the open transaction: the commit's thousands of rows a round bind faster than as dicts by
        name (decision 0051)."""
        if self._cursor is None:
            raise StoreError("the exposure store writes only inside transaction()")
        text = self._sql.get(sql)
        if text is None:
            text = self._sql[sql] = sql.replace("?", "%s") if self.dialect == "postgresql" else sql
        self._cursor.executemany(text, rows)

    def _read(self, statement, params: dict | None = None):
        """Run a read: inside the open transaction when the writing thread reads, else on a pooled connection
        (its rows fetched before the connection goes back)."""
        if self._cursor is not None and self._owner == threading.get_ident():
            raise StoreError("a read inside the store's own transaction must use _exec")
        with self._guard, self._errors("could not read"), self.engine.connect() as conn:
            return _Buffered(conn.execute(statement, params or {}))

    def _upsert(self, table: sa.Table, rows: list[dict], keys: tuple[str, ...]) -> None:
        if rows:
            updates = ", ".join(f"{c} = excluded.{c}" for c in rows[0] if c not in keys)
            self._exec(_insert_sql(table, rows[0], f" ON CONFLICT ({', '.join(keys)}) DO UPDATE SET {updates}"), rows)

    @contextmanager
    def _errors(self, what: str) -> Iterator[None]:
        try:
            yield
        except (SQLAlchemyError, self._dbapi.Error) as error:
            raise StoreError(f"{what} the exposure store at {self.label}: "
                             f"{sqlstore.reason(error, self.url.password)}") from error


def migrate(conn: Connection) -> int:
    """Bring the store on ``conn`` to :data:`SCHEMA_VERSION`; returns the version it had (0: before versions,
    -1: a new store)."""
    with conn.begin():
        inspector = sa.inspect(conn)
        new = not inspector.has_table("raw")
        versioned = inspector.has_table(version_table.name)
        found = -1 if new else (conn.execute(sa.select(version_table.c.version)).scalar() or 0) if versioned else 0
        if new:
            metadata.create_all(conn)
            conn.execute(version_table.insert(), {"version": SCHEMA_VERSION})
            return found
    for version, _, step in MIGRATIONS:
        if version > found:
            with conn.begin():
                step(conn)
    with conn.begin():
        metadata.create_all(conn)  # new tables; the indexes of tables that were there already:
        for table in metadata.sorted_tables:
            for index in table.indexes:
                index.create(conn, checkfirst=True)
        conn.execute(version_table.delete())
        conn.execute(version_table.insert(), {"version": SCHEMA_VERSION})
    return found


class _Buffered:
    """A read's rows fetched while its connection was open."""

    def __init__(self, result):
        self._rows = result.fetchall()

    def __iter__(self):
        return iter(self._rows)

    def fetchall(self) -> list:
        return self._rows

    def first(self):
        return self._rows[0] if self._rows else None

    def scalar_one(self):
        return self._rows[0][0]


_EVENT_ROW = dict.fromkeys(("kind", "time", "subject", "source", "data", "received"))
_OUTBOX_ROW = dict.fromkeys(("sink", "event"))


def _insert_sql(table: sa.Table, row: dict, conflict: str = "") -> str:
    """INSERT of ``row``'s columns into ``table`` with named parameters (SQLite and PostgreSQL share the syntax,
    ON CONFLICT included)."""
    return (f"INSERT INTO {table.name} ({', '.join(row)}) VALUES ({', '.join(':' + c for c in row)}){conflict}")


def _rows_sql(table: sa.Table, keys: tuple[str, ...] = ()) -> str:
    """INSERT of a row of each of ``table``'s columns in their order, as positional parameters (``?``); an upsert
    on ``keys`` when given (the other columns updated)."""
    columns = [c.name for c in table.columns]
    conflict = (f" ON CONFLICT ({', '.join(keys)}) DO UPDATE SET "
                + ", ".join(f"{c} = excluded.{c}" for c in columns if c not in keys)) if keys else ""
    return f"INSERT INTO {table.name} ({', '.join(columns)}) VALUES ({', '.join('?' * len(columns))}){conflict}"


_APPLIED_SQL = _rows_sql(applied_table)
"""(device, boot, seq, received time) rows of the ledger."""
_STREAMS_SQL = _rows_sql(streams_table, ("device",))
"""(device, state, filter) rows, inserted or updated."""
_DAYS_SQL = _rows_sql(days_table, ("subject", "day"))
"""(subject, day, energy, seconds, eav_at, elv_at, hands) rows, inserted or updated."""


def _expired_sql(dialect: str) -> str:
    """Raw rows received at or before :by, from the covering expiry index."""
    hint = " INDEXED BY raw_expiry" if dialect == "sqlite" else ""
    return f"SELECT device, seq FROM raw{hint} WHERE received_time <= :by"


def _raw_columns():
    t = raw_table.c
    return (t.device, t.seq, t.device_time, t.received_time, t.fs, t.full_scale, t.n, t.samples, t.scale, t.codec)


def _batch(row) -> AccelBatch:
    d, s, t, rt, fs, fsc, n, blob, scale, codec = row
    return AccelBatch(d, int(s), t, fs, _xyz(bytes(blob), n, scale, codec), fsc, rt, scale)


def _packed(batch: AccelBatch, compress: bool) -> dict:
    """{samples, scale, codec}: int16 counts when xyz is exactly counts x float32(scale) (as decoded from an
    int16 payload; dividing back errs by under 0.01 count), else float32 and no scale; zlib over byte planes
    with ``compress``."""
    scale, blob = None, None
    if batch.scale is not None:
        scale32 = np.float32(batch.scale)
        with np.errstate(all="ignore"):
            counts = np.rint(batch.xyz / scale32)
            if np.array_equal(np.clip(counts, -32768, 32767).astype(np.float32) * scale32, batch.xyz):
                blob, scale = counts.astype("<i2").tobytes(), batch.scale
    if blob is None:
        blob = np.ascontiguousarray(batch.xyz, dtype=np.float32).tobytes()
    if not compress:
        return {"samples": blob, "scale": scale, "codec": RAW_PLAIN}
    return {"samples": _compressed(blob, scale, RAW_PLAIN), "scale": scale, "codec": RAW_ZLIB}


def _compressed(blob: bytes, scale: float | None, codec: int) -> bytes:
    """A stored blob, compressed (as it is when it already was): the samples' low bytes as they are (sensor noise
    does not compress), their high bytes through zlib (level 1): ~0.6 of the size at a third of zlib's time over
    all bytes."""
    if codec == RAW_ZLIB:
        return blob
    width = 2 if scale is not None else 4
    planes = np.frombuffer(blob, np.uint8).reshape(-1, width)
    return planes[:, :width // 2].tobytes() + zlib.compress(planes[:, width // 2:].tobytes(), 1)


def _xyz(blob: bytes, n: int, scale: float | None, codec: int | None = RAW_PLAIN) -> np.ndarray:
    width = 2 if scale is not None else 4
    if codec == RAW_ZLIB:
        low_size = n * 3 * (width // 2)
        low = np.frombuffer(blob[:low_size], np.uint8).reshape(-1, width // 2)
        high = np.frombuffer(zlib.decompress(blob[low_size:]), np.uint8).reshape(-1, width - width // 2)
        blob = np.concatenate([low, high], axis=1).tobytes()
    if scale is None:
        return np.frombuffer(blob, np.float32).reshape(n, 3)
    return np.frombuffer(blob, "<i2").reshape(n, 3).astype(np.float32) * np.float32(scale)


def _add_day(found: dict, key: tuple[str, str], hands: dict, eav: float | None, elv: float | None) -> None:
    """Add one contribution to a worker-day: energy and seconds per hand, the earliest EAV and ELV times."""
    if key not in found:
        found[key] = ({hand: list(figures) for hand, figures in hands.items()}, eav, elv)
        return
    summed, eav0, elv0 = found[key]
    for hand, (energy, seconds) in hands.items():
        figures = summed.setdefault(hand, [0.0, 0.0])
        figures[0] += energy
        figures[1] += seconds
    found[key] = (summed, _earliest(eav0, eav), _earliest(elv0, elv))


def _earliest(a: float | None, b: float | None) -> float | None:
    return b if a is None else a if b is None else min(a, b)


def _reused_encoder() -> Callable[[Any], str]:
    """``json.dumps`` with its default settings, through one C encoder made once: ``json.dumps`` makes a new one
    for every call, about 40 % of the time to encode a stream's small state (thousands per commit). Plain
    ``json.dumps`` where the C encoder is missing or encodes a sample differently."""
    make = getattr(json.encoder, "c_make_encoder", None)
    if make is None:
        return json.dumps
    base = json.JSONEncoder()
    try:
        encode = make(None, base.default, json.encoder.encode_basestring_ascii, None, base.key_separator,
                      base.item_separator, False, False, True)
        sample = [[1, 2.5, None, True, "é\"x"], {"k": [float("inf"), -0.0, 1e300]}]
        if "".join(encode(sample, 0)) != json.dumps(sample):
            return json.dumps
    except (TypeError, ValueError):
        return json.dumps
    return lambda value: "".join(encode(value, 0))


_dumps = _reused_encoder()


def _hands_json(hands: dict[str, list[float]]) -> str | None:
    """Per-hand figures as JSON; None for the usual single unnamed hand (the energy/seconds columns hold it)."""
    return None if len(hands) == 1 and "" in hands else json.dumps(hands)
