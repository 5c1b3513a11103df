"""The server's settings section (``Settings.server``, ``BIM2RDT_SERVER__*``): where it binds, who may read what
(bearer tokens, stored as SHA-256 digests), the request limits and the live stream's pacing. Only pydantic is
imported here, so reading the settings stays light; the edge (``bim2rdt serve``) unpacks it."""

from __future__ import annotations

from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, field_validator

ROLES = ("viewer", "safety", "admin")
"""viewer: the twin, exposure under pseudonyms, events; safety (the safety officer): also identities behind
pseudonyms and raw sensor windows, each reveal audited; admin: also the audit log."""


class TokenEntry(BaseModel):
    """One bearer token: who holds it (``name``, written into the audit log), its role, and the SHA-256 hex
    digest of the token (the token itself is never stored: ``bim2rdt serve token`` makes one and its digest)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    name: str = Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.@ -]+$")
    role: str = Field(description="viewer, safety or admin.")
    sha256: str = Field(pattern=r"^[0-9a-f]{64}$", description="hashlib.sha256(token).hexdigest().")

    @field_validator("role")
    @classmethod
    def _known_role(cls, role: str) -> str:
        if role not in ROLES:
            raise ValueError(f"role must be one of {', '.join(ROLES)}, got {role!r}")
        return role


class ServerConfig(BaseModel):
    """The dashboard and API server."""

    model_config = ConfigDict(extra="forbid")

    host: str = Field("127.0.0.1", description="Address to bind; 127.0.0.1 keeps the server on this machine.")
    port: int = Field(8000, ge=0, le=65535, description="TCP port (0: any free port).")
    tokens: list[TokenEntry] = Field(default_factory=list, description="Bearer tokens as JSON: "
                                     '[{"name": "alice", "role": "safety", "sha256": "<hex digest>"}].')
    audit_log: Path | None = Field(None, description="Append-only audit log of identity and raw-data reveals "
                                   "(JSON lines); None means data_dir/server/audit.jsonl.")
    max_body_bytes: int = Field(4096, ge=64, le=1_048_576, description="Largest request body accepted, bytes.")
    write_rate_per_minute: int = Field(30, ge=1, le=10_000, description="Write requests per token per minute "
                                       "(a burst of this many, refilled evenly).")
    raw_window_max_s: float = Field(10.0, gt=0, le=600, description="Longest raw sensor window one request may "
                                    "reveal, seconds.")
    exposure_period_s: float = Field(1.0, gt=0, le=60, description="How often the live stream sends the "
                                     "workers' exposure, seconds.")
    twin_poll_s: float = Field(0.5, gt=0, le=60, description="How often the server looks for new twin records "
                               "(other robots may append), seconds.")
    max_connections: int = Field(256, ge=8, le=4096, description="Open connections at most (live streams "
                                 "included); one beyond is answered 503 and closed at once.")
    header_timeout_s: float = Field(10.0, gt=0, le=300, description="Seconds a connection has to send a whole "
                                    "request head (from opening, or from its last response); then it is closed.")
    keep_alive_s: int = Field(5, ge=1, le=300, description="Seconds an idle keep-alive connection is kept after "
                              "a response.")
    max_header_bytes: int = Field(16384, ge=4096, le=1_048_576, description="Largest request head accepted, "
                                  "bytes.")
    stream_backlog: int = Field(2000, ge=10, le=1_000_000, description="Stream messages kept for clients that "
                                "reconnect with Last-Event-ID.")

    def resolved_audit_log(self, data_dir: Path) -> Path:
        """Where the audit log of revealed identities goes.

        Args:
            data_dir: The folder of persistent state (``Settings.data_dir``).

        Returns:
            ``audit_log``, or ``data_dir/server/audit.jsonl`` when none is set.
        """
        return self.audit_log or Path(data_dir) / "server" / "audit.jsonl"
