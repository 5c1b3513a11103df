"""A PostgreSQL server for the tests of the twin and the exposure store: the one CI starts
(``BIM2RDT_TEST_POSTGRES_URL``), else a private throwaway cluster started from Debian's binaries on a free port (as
the postgres user when run as root), and a fresh database per test."""

from __future__ import annotations

import glob
import os
import shutil
import socket
import subprocess
import tempfile
import time
import uuid
from contextlib import contextmanager
from pathlib import Path

import sqlalchemy as sa

ENV_URL = "BIM2RDT_TEST_POSTGRES_URL"


def pg_bindir() -> Path | None:
    """Folder of initdb/pg_ctl: on PATH, else Debian's newest /usr/lib/postgresql/<version>/bin."""
    if on_path := shutil.which("pg_ctl"):
        return Path(on_path).parent
    found = sorted(glob.glob("/usr/lib/postgresql/*/bin/pg_ctl"), key=lambda p: int(Path(p).parts[-3]))
    return Path(found[-1]).parent if found else None


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _as_postgres(command: list[str]) -> list[str]:
    return ["runuser", "-u", "postgres", "--", *command] if os.geteuid() == 0 else command


@contextmanager
def private_cluster(bindir: Path):
    """initdb + pg_ctl start on 127.0.0.1:<free port>; yields the admin URL; stops and removes it after."""
    folder = Path(tempfile.mkdtemp(prefix="bim2rdt-pg-"))
    if os.geteuid() == 0:
        shutil.chown(folder, "postgres")
    data, port = folder / "data", _free_port()
    try:
        subprocess.run(_as_postgres([str(bindir / "initdb"), "-D", str(data), "-U", "postgres", "-A", "trust"]),
                       check=True, capture_output=True)
        options = f"-p {port} -k {folder} -c listen_addresses=127.0.0.1 -c fsync=off"
        subprocess.run(_as_postgres([str(bindir / "pg_ctl"), "-D", str(data), "-o", options, "-l",
                                     str(folder / "log"), "-w", "start"]), check=True, capture_output=True)
        try:
            yield f"postgresql+psycopg://postgres@127.0.0.1:{port}/postgres"
        finally:
            subprocess.run(_as_postgres([str(bindir / "pg_ctl"), "-D", str(data), "-m", "fast", "-w", "stop"]),
                           capture_output=True)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


@contextmanager
def fresh_database(admin_url: str):
    """A new empty database on the server of ``admin_url``; yields its URL and drops it after."""
    name = f"twin_test_{uuid.uuid4().hex[:12]}"
    admin = sa.create_engine(admin_url, isolation_level="AUTOCOMMIT")
    try:
        with admin.connect() as conn:
            conn.exec_driver_sql(f'CREATE DATABASE "{name}"')
        yield sa.make_url(admin_url).set(database=name).render_as_string(hide_password=False)
        _drop_database(admin, name)
    finally:
        admin.dispose()


def _drop_database(admin: sa.Engine, name: str, *, attempts: int = 20) -> None:
    """DROP DATABASE ... WITH (FORCE), retried while an autovacuum worker holds it.

    FORCE may only end sessions of roles the test role is a member of; an autovacuum worker on the fresh database
    has no role, so PostgreSQL refuses (InsufficientPrivilege) until that worker finishes, which takes moments.
    """
    for attempt in range(attempts):
        try:
            with admin.connect() as conn:
                conn.exec_driver_sql(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')
            return
        except sa.exc.ProgrammingError as error:
            if "pg_signal_backend" not in str(error) or attempt == attempts - 1:
                raise
            time.sleep(0.25)
