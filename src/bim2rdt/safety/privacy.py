"""Workers appear under pseudonyms; only the safety role may turn a pseudonym back into a name.

A pseudonym is a keyed hash (HMAC-SHA256 with the site secret, ``Settings.hav.site_secret``) of the worker id:
stable across days and restarts, not reversible without the secret, different on every site. The identity map
(pseudonym -> worker id) lives in its own SQLite file (through SQLAlchemy, as every store of the project) in a
private folder (mode 0700, file 0600), apart from the exposure store, and :meth:`IdentityMap.real_name` refuses
any role but ``safety``.
"""

from __future__ import annotations

import hashlib
import hmac
import os
from pathlib import Path

import sqlalchemy as sa

from bim2rdt import sqlstore
from bim2rdt.safety.errors import AccessDenied, HavError, StoreError

SAFETY_ROLE = "safety"
_metadata = sa.MetaData()
identity_table = sa.Table("identity", _metadata, sa.Column("pseudonym", sa.Text, primary_key=True),
                          sa.Column("worker", sa.Text, nullable=False))


def pseudonym(worker_id: str, secret: str) -> str:
    """The worker's pseudonym on this site: a keyed hash, so the monitor's records name no one.

    Args:
        worker_id: The worker's real id.
        secret: The site's key (``hav.site_secret``).

    Returns:
        'w-' + 16 hex digits of HMAC-SHA256(secret, worker id).

    Raises:
        HavError: An empty worker id.
    """
    if not worker_id:
        raise HavError("worker id must not be empty")
    return "w-" + hmac.new(secret.encode(), worker_id.encode(), hashlib.sha256).hexdigest()[:16]


class IdentityMap:
    """The pseudonym -> worker id map, readable only by the safety role. Its file and folder are private to the
    user (0600, 0700).

    Args:
        path: The SQLite file; None keeps the map in memory (a throw-away monitor, e.g. analysing a file).
        role: The reader's role; only ``safety`` may read real names.
    """

    def __init__(self, path: Path | None, role: str):
        self.path, self.role = (Path(path) if path is not None else None), role
        if self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            os.chmod(self.path.parent, 0o700)
        url = sqlstore.parse_url(f"sqlite:///{self.path}" if self.path else "sqlite://", StoreError, "the identity map",
                                 "sqlite:///private/identity.sqlite")
        self._engine = sqlstore.make_engine(url, StoreError, "the identity map", ("synchronous=FULL",))
        with self._engine.begin() as conn:
            _metadata.create_all(conn)
        if self.path is not None:
            os.chmod(self.path, 0o600)

    def remember(self, pseudonym_: str, worker_id: str) -> None:
        """Record who is behind a pseudonym (any role may add; the monitor does when a session starts).

        Args:
            pseudonym_: The pseudonym.
            worker_id: The worker's real id.
        """
        insert = sa.dialects.sqlite.insert(identity_table).values(pseudonym=pseudonym_, worker=worker_id)
        with self._engine.begin() as conn:
            conn.execute(insert.on_conflict_do_update(index_elements=["pseudonym"], set_={"worker": worker_id}))

    def real_name(self, pseudonym_: str) -> str | None:
        """The worker id behind a pseudonym.

        Args:
            pseudonym_: The pseudonym.

        Returns:
            The worker's real id, or None when the map does not hold the pseudonym.

        Raises:
            AccessDenied: The map was opened by a role other than ``safety``.
        """
        if self.role != SAFETY_ROLE:
            raise AccessDenied(f"role {self.role!r} may not read the identity map (only {SAFETY_ROLE!r})")
        with self._engine.connect() as conn:
            return conn.execute(sa.select(identity_table.c.worker).where(identity_table.c.pseudonym == pseudonym_)
                                ).scalar()

    def close(self) -> None:
        """Close the map's database connections."""
        self._engine.dispose()


class PartitionIdentities:
    """The identity maps of the NATS path's monitors, read together (role ``safety``): each partition K of N
    keeps its own under ``<hav folder>/partition-K-of-N/private/``, and a single monitor under ``<hav
    folder>/private/``. Maps that appear later (a partition started after the reader) are found at the next look.

    Args:
        hav_folder: The monitors' HAV data folder (``<data_dir>/hav``).
        role: The reader's role; only ``safety`` may read real names.
    """

    def __init__(self, hav_folder: Path, role: str):
        self.hav_folder, self.role = Path(hav_folder), role
        self._maps: dict[Path, IdentityMap] = {}

    def paths(self) -> list[Path]:
        """The identity files there now: the single monitor's first, then each partition's.

        Returns:
            Their paths, in the order :meth:`real_name` asks them.
        """
        single = self.hav_folder / "private" / "identity.sqlite"
        return [single] * single.is_file() + sorted(self.hav_folder.glob("partition-*-of-*/private/identity.sqlite"))

    def real_name(self, pseudonym_: str) -> str | None:
        """The worker id behind a pseudonym, from whichever map holds it.

        Args:
            pseudonym_: The pseudonym.

        Returns:
            The worker's real id, or None when no map holds the pseudonym.

        Raises:
            AccessDenied: Opened by a role other than ``safety``.
        """
        if self.role != SAFETY_ROLE:
            raise AccessDenied(f"role {self.role!r} may not read the identity map (only {SAFETY_ROLE!r})")
        for path in self.paths():
            identity = self._maps.get(path) or self._maps.setdefault(path, IdentityMap(path, self.role))
            if (name := identity.real_name(pseudonym_)) is not None:
                return name
        return None

    def close(self) -> None:
        """Close every map opened so far."""
        for identity in self._maps.values():
            identity.close()
