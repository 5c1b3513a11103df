"""One way to persist: a SQLAlchemy URL to an SQLite file (one process, nothing to start) or a PostgreSQL server
(several processes), shared by the twin's event store and the HAV monitor's exposure store.

``parse_url`` accepts a URL or a plain path (an SQLite file) and refuses any other backend; ``make_engine``
builds the engine: for SQLite with the driver's own transaction handling off (so a writer can ``BEGIN
IMMEDIATE``: the SQLAlchemy recipe for pysqlite), WAL journal and the caller's pragmas, for PostgreSQL with a
connect timeout and pre-ping. Errors are the caller's typed error, one line, never the password.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import sqlalchemy as sa
from sqlalchemy.engine import URL, Connection, Engine
from sqlalchemy.exc import ArgumentError, NoSuchModuleError, SQLAlchemyError
from sqlalchemy.pool import StaticPool

from bim2rdt.errors import Bim2RdtError

CONNECT_TIMEOUT_S = 5
"""How long opening a PostgreSQL store waits for the server before it says it cannot be reached."""
SQLITE_BUSY_TIMEOUT_S = 60.0
"""How long an SQLite writer waits for another one to commit (the caller may pass its own)."""
WRITE_OPTION = "bim2rdt_write"
"""Execution option of a connection whose SQLite transactions begin IMMEDIATE (take the write lock at BEGIN)."""


SCHEMA_LOCK = 0x62696D32
"""The PostgreSQL advisory lock key held while a store creates or migrates its schema (ASCII 'bim2')."""


@contextmanager
def schema_lock(conn: Connection) -> Iterator[None]:
    """Hold the schema lock on ``conn`` (PostgreSQL; a no-op for SQLite, whose writers serialise anyway).

    Processes that open a fresh PostgreSQL store together (the NATS path's partitions) would otherwise race to
    create the same tables and one fails with ``duplicate key ... pg_type_typname_nsp_index``. A session-level
    advisory lock, released on exit: the schema steps may span several transactions.

    Args:
        conn: An open connection, outside any transaction.

    Yields:
        Nothing; the lock is held until the block ends.
    """
    if conn.dialect.name != "postgresql":
        yield
        return
    with conn.begin():
        conn.execute(sa.text("SELECT pg_advisory_lock(:key)"), {"key": SCHEMA_LOCK})
    try:
        yield
    finally:
        with conn.begin():
            conn.execute(sa.text("SELECT pg_advisory_unlock(:key)"), {"key": SCHEMA_LOCK})


def parse_url(url: str, error: type[Bim2RdtError], what: str, example: str) -> URL:
    """``url`` as a SQLAlchemy URL; ``error`` if it is not one, or names a backend other than SQLite or
    PostgreSQL. ``what`` names the store in messages ("the twin"), ``example`` is the SQLite URL they suggest."""
    try:
        parsed = sa.make_url(url)
    except ArgumentError:
        raise error(f"not a database URL: {str(url).split('@')[-1]!r} (expected {example} or "
                    "postgresql+psycopg://user:password@host/db)") from None
    if parsed.get_backend_name() not in ("sqlite", "postgresql"):
        raise error(f"{what} is stored in SQLite or PostgreSQL, not {parsed.get_backend_name()} "
                    f"({parsed.render_as_string(hide_password=True)})")
    return parsed


def label(url: URL) -> str:
    """The URL as it may be shown: without its password."""
    return url.render_as_string(hide_password=True)


def is_memory(url: URL) -> bool:
    return url.get_backend_name() == "sqlite" and url.database in (None, "", ":memory:")


def make_engine(url: URL, error: type[Bim2RdtError], what: str, pragmas: Sequence[str] = ("synchronous=FULL",),
                busy_timeout_s: float = SQLITE_BUSY_TIMEOUT_S) -> Engine:
    """The engine of ``url``: SQLite (WAL, ``pragmas`` run on every new connection; an in-memory database is one
    connection shared by all threads) or PostgreSQL. ``error`` when the driver is missing or the folder of an
    SQLite file cannot be made."""
    try:
        if url.get_backend_name() == "sqlite":
            return _sqlite_engine(url, error, what, pragmas, busy_timeout_s)
        return sa.create_engine(url, connect_args={"connect_timeout": CONNECT_TIMEOUT_S}, pool_pre_ping=True)
    except (NoSuchModuleError, ModuleNotFoundError) as missing:
        raise error(f"cannot open {label(url)}: its driver is not installed ({missing}); for PostgreSQL install the "
                    "'postgres' extra: pip install 'bim2rdt[postgres]'") from None


def write_connection(engine: Engine) -> Connection:
    """A connection whose transactions take the write lock at BEGIN (SQLite: a deferred transaction that reads
    before it writes can fail at once with "database is locked" instead of waiting its turn)."""
    return engine.connect().execution_options(**{WRITE_OPTION: True})


def reason(failure: SQLAlchemyError, password: str | None) -> str:
    """The driver's first line (never the SQL, never the password)."""
    original = getattr(failure, "orig", None) or failure
    text = " ".join(str(original).strip().splitlines()[:1]) or type(original).__name__
    return text.replace(password, "***") if password else text


def _sqlite_engine(url: URL, error: type[Bim2RdtError], what: str, pragmas: Sequence[str], busy_timeout_s: float) -> Engine:
    memory = is_memory(url)
    if not memory:
        try:
            Path(url.database).parent.mkdir(parents=True, exist_ok=True)
        except OSError as failure:
            raise error(f"cannot reach {what} at {label(url)}: {failure.strerror}: {failure.filename}") from None
    extra = {"poolclass": StaticPool} if memory else {}
    engine = sa.create_engine(url, connect_args={"timeout": busy_timeout_s, "check_same_thread": False}, **extra)

    @sa.event.listens_for(engine, "connect")
    def _on_connect(dbapi_connection, _record) -> None:
        dbapi_connection.isolation_level = None
        cursor = dbapi_connection.cursor()
        for pragma in (*[p for p in pragmas if p.startswith("page_size")], "journal_mode=WAL",
                       *[p for p in pragmas if not p.startswith("page_size")]):
            cursor.execute(f"PRAGMA {pragma}")
        cursor.close()

    @sa.event.listens_for(engine, "begin")
    def _on_begin(conn: Connection) -> None:
        conn.exec_driver_sql("BEGIN IMMEDIATE" if conn.get_execution_options().get(WRITE_OPTION) else "BEGIN")

    return engine
