"""The twin's append-only event store, through SQLAlchemy Core: an SQLite file by default (nothing to start),
PostgreSQL by URL when several robots share one twin.

One table, ``twin_events``, is only ever inserted into. Writers serialize: SQLite through ``BEGIN IMMEDIATE``
(WAL journal, synchronous=FULL, so a committed event survives a crash), PostgreSQL through a transaction-level
advisory lock. So ``seq`` order is commit order, a reader that has seen ``seq`` n has seen everything before it,
and a writer that first catches up on what others appended decides on the present state. A write that fails
rolls back whole: the history stays as it was.
"""

from __future__ import annotations

import json
import numbers
import time
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import sqlalchemy as sa
from sqlalchemy.engine import URL, Connection, Engine
from sqlalchemy.exc import SQLAlchemyError

from bim2rdt import sqlstore
from bim2rdt.twin.errors import TwinError
from bim2rdt.twin.records import TwinEvent
from bim2rdt.twin.text import checked_text, may_need_mending, mended

SQLITE_BUSY_TIMEOUT_S = 60.0
"""How long an SQLite writer waits for another one to commit."""
MAX_SEQ = 2**63 - 1
"""The largest seq either backend can hold (a signed 64-bit integer)."""
_WRITE_LOCK = 0x62696D32  # "bim2": the advisory lock key of the twin's writers on PostgreSQL

_metadata = sa.MetaData()
events_table = sa.Table(
    "twin_events", _metadata,
    sa.Column("seq", sa.BigInteger().with_variant(sa.Integer(), "sqlite"), primary_key=True, autoincrement=True),
    sa.Column("kind", sa.String(16), nullable=False),
    sa.Column("time", sa.Double(), nullable=False),
    sa.Column("global_id", sa.String(64), nullable=True, index=True),
    sa.Column("source", sa.String(128), nullable=False),
    sa.Column("data", sa.Text(), nullable=False),
    sa.Column("recorded", sa.Double(), nullable=False),
    sa.Index("twin_events_time", "time"),
)
runs_table = sa.Table(
    "twin_runs", _metadata,
    sa.Column("run", sa.BigInteger().with_variant(sa.Integer(), "sqlite"), primary_key=True, autoincrement=True),
    sa.Column("source", sa.String(128), nullable=False),
    sa.Column("started", sa.Double(), nullable=False),
    sa.Column("finished", sa.Double(), nullable=True),
)
"""Runs that build a store whole (verify's twin.db): a row written with the tables, ``finished`` set after the
last event. A store with a row not finished was left by a run that stopped (killed, failed): readers say so."""


@dataclass(frozen=True)
class NewEvent:
    """An event about to be appended (the store gives it its ``seq``)."""

    kind: str
    time: float
    global_id: str | None
    source: str
    data: dict[str, Any] = field(default_factory=dict)


class EventStore:
    """Opens (and creates) the event table at a URL; appends in locked transactions; reads in order."""

    def __init__(self, engine: Engine, url: URL):
        self.engine, self.url = engine, url
        self.label = url.render_as_string(hide_password=True)
        self.run: int | None = None
        """The run this store was opened to build (:meth:`open`'s ``run``), until :meth:`finish_run`."""

    @classmethod
    def open(cls, url: str, create: bool = True, run: str | None = None) -> EventStore:
        """Connect and create the table if absent (with ``create``; without it a store that has no history yet is
        a TwinError); TwinError (naming the URL without its password) if the store cannot be reached. With
        ``run`` (its source, e.g. "verify"), a run that builds the store whole is marked started in the same
        transaction as the tables, and is unfinished until :meth:`finish_run`."""
        parsed = _parse(url)
        label = parsed.render_as_string(hide_password=True)
        if not create and parsed.get_backend_name() == "sqlite" and not Path(parsed.database or "").is_file():
            raise TwinError(f"no twin at {label}: the file does not exist")
        store = cls(_engine(parsed), parsed)
        try:
            with store._errors("cannot reach the twin at"), store._write_connection() as conn, conn.begin():
                store._lock(conn)
                if not create and not sa.inspect(conn).has_table(events_table.name):
                    raise TwinError(f"no twin at {label}: it has no {events_table.name} table")
                _metadata.create_all(conn)
                if run is not None:
                    store.run = conn.execute(runs_table.insert().returning(runs_table.c.run),
                                             {"source": checked_text(run, "source"), "started": time.time()}
                                             ).scalar_one()
        except TwinError:
            store.close()
            raise
        return store

    def finish_run(self) -> None:
        """Mark the run :meth:`open` started as finished: written after its last event, so a store whose run
        stopped before it is known partial."""
        if self.run is None:
            raise TwinError("no run to finish: open the store with run=...")
        with self.writing() as writer:
            writer.conn.execute(runs_table.update().where(runs_table.c.run == self.run).values(finished=time.time()))
        self.run = None

    def unfinished_runs(self) -> list[tuple[str, float]]:
        """(source, started: UTC epoch seconds) of each run that began building this store and never finished."""
        query = sa.select(runs_table.c.source, runs_table.c.started).where(runs_table.c.finished.is_(None))
        with self._errors("cannot read the twin at"), self.engine.connect() as conn:
            if not sa.inspect(conn).has_table(runs_table.name):
                return []
            return [(row.source, float(row.started)) for row in conn.execute(query.order_by(runs_table.c.run))]

    def close(self) -> None:
        self.engine.dispose()

    @contextmanager
    def writing(self) -> Iterator[Writer]:
        """A transaction that holds the writers' lock; commits on exit, rolls back whole on any error."""
        with self._errors("could not record into the twin at", "; the history is unchanged"):
            with self._write_connection() as conn, conn.begin():
                self._lock(conn)
                yield Writer(conn)

    def read(self, *, after: int = 0, until: float | None = None, since: float | None = None,
             kinds: Iterable[str] | None = None, global_id: str | None = None,
             by_time: bool = False) -> list[TwinEvent]:
        """Events with seq > ``after`` and ``since`` < time <= ``until``, of ``kinds``, about ``global_id``;
        in store order, or in time order (ties by seq) with ``by_time``. A seq ``after`` beyond any a store can
        hold has nothing after it."""
        if isinstance(after, bool) or not isinstance(after, numbers.Integral):
            raise TwinError(f"after is a seq (a whole number), got {after!r}")
        if after >= MAX_SEQ:
            return []
        t = events_table.c
        query = sa.select(events_table).where(t.seq > max(int(after), 0))
        if until is not None:
            query = query.where(t.time <= until)
        if since is not None:
            query = query.where(t.time > since)
        if kinds is not None:
            query = query.where(t.kind.in_(list(kinds)))
        if global_id is not None:
            query = query.where(t.global_id == global_id)
        query = query.order_by(t.time, t.seq) if by_time else query.order_by(t.seq)
        with self._errors("cannot read the twin at"), self.engine.connect() as conn:
            return [_event(row) for row in conn.execute(query)]

    def _write_connection(self) -> Connection:
        """A connection whose transactions take the write lock at BEGIN (SQLite: a deferred transaction that
        reads before it writes can fail at once with "database is locked" instead of waiting its turn)."""
        return sqlstore.write_connection(self.engine)

    def _lock(self, conn: Connection) -> None:
        if conn.dialect.name == "postgresql":
            conn.execute(sa.text("SELECT pg_advisory_xact_lock(:key)"), {"key": _WRITE_LOCK})

    @contextmanager
    def _errors(self, what: str, after: str = "") -> Iterator[None]:
        try:
            yield
        except SQLAlchemyError as error:
            raise TwinError(f"{what} {self.label}: {_reason(error, self.url.password)}{after}") from None


class Writer:
    """Inside a write transaction: catch up on others' events, then append."""

    def __init__(self, conn: Connection):
        self.conn = conn

    def read_after(self, seq: int) -> list[TwinEvent]:
        query = sa.select(events_table).where(events_table.c.seq > seq).order_by(events_table.c.seq)
        return [_event(row) for row in self.conn.execute(query)]

    def append(self, event: NewEvent) -> TwinEvent:
        """Insert one event; returns it with its seq (visible to others at commit). Its source and GlobalId are
        checked against the columns' limits here, so SQLite refuses what PostgreSQL would."""
        global_id = None if event.global_id is None else checked_text(event.global_id, "GlobalId")
        row = {"kind": event.kind, "time": float(event.time), "global_id": global_id,
               "source": checked_text(event.source, "source"), "data": _dumps(event.data), "recorded": time.time()}
        seq = self.conn.execute(events_table.insert().returning(events_table.c.seq), row).scalar_one()
        return TwinEvent(seq=int(seq), kind=row["kind"], time=row["time"], global_id=row["global_id"],
                         source=row["source"], data=json.loads(row["data"]), recorded=row["recorded"])

    def append_all(self, events: Sequence[NewEvent]) -> list[TwinEvent]:
        return [self.append(event) for event in events]


def _parse(url: str) -> URL:
    return sqlstore.parse_url(url, TwinError, "the twin", "sqlite:///path/twin.db")


def _engine(url: URL) -> Engine:
    return sqlstore.make_engine(url, TwinError, "the twin", ("synchronous=FULL",), SQLITE_BUSY_TIMEOUT_S)


def _event(row) -> TwinEvent:
    """A stored row as an event; text a history written before the checks may hold is mended (see ``text``)."""
    data = json.loads(row.data)
    if may_need_mending(row.data):
        data = mended(data)
    return TwinEvent(seq=int(row.seq), kind=row.kind, time=float(row.time), global_id=mended(row.global_id),
                     source=mended(row.source), data=data, recorded=float(row.recorded))



def _dumps(data: dict) -> str:
    try:
        return json.dumps(data, allow_nan=False, sort_keys=True)
    except (TypeError, ValueError) as error:
        raise TwinError(f"an event holds a value the history cannot store ({error})") from None


def _reason(error: SQLAlchemyError, password: str | None) -> str:
    return sqlstore.reason(error, password)
