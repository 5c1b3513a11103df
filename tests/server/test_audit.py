"""The audit log of reveals: a reveal is answered only once its whole record is on disk (a short write, a full
disk or a failed sync is a 503 with nothing revealed), a torn line is reported and never glued to the next
record, refused attempts are audited too, and restarting the demo server keeps the log."""

from __future__ import annotations

import errno
import json
import os

import httpx
import pytest

from server_helpers import auth, config_with_tokens

REASON = {"reason": "HAV health surveillance referral"}


class FlakyDisk:
    """The OS-write seam of an AuditLog: passes writes through to ``os.write`` until told to fail, then writes
    only ``keep`` bytes of the next call (a short write) or raises ENOSPC."""

    def __init__(self):
        self.mode, self.keep = None, 0

    def __call__(self, fd: int, data: bytes) -> int:
        if self.mode == "short":
            self.mode = "full"  # the retry of the rest finds the disk full
            return os.write(fd, data[:self.keep])
        if self.mode == "full":
            raise OSError(errno.ENOSPC, "No space left on device")
        return os.write(fd, data)


def test_a_short_write_then_a_full_disk_fails_the_append_and_the_next_record_starts_on_its_own_line(tmp_path):
    from bim2rdt.server.audit import AuditError, AuditLog

    disk = FlakyDisk()
    log = AuditLog(tmp_path / "audit.jsonl", write=disk)
    log.append("ann", "safety", "identity", "w-1", "referral")
    disk.mode, disk.keep = "short", 20
    with pytest.raises(AuditError, match="cannot be written"):
        log.append("ann", "safety", "identity", "w-2", "referral")
    disk.mode = None
    log.append("ann", "safety", "raw", "w-3", "referral")
    entries = log.entries()
    assert [e["action"] for e in entries] == ["identity", "damaged", "raw"]
    assert entries[1]["detail"]["line"] == 2 and entries[1]["detail"]["bytes"] == 20
    assert [e["subject"] for e in entries if e["action"] != "damaged"] == ["w-1", "w-3"]
    lines = (tmp_path / "audit.jsonl").read_bytes().split(b"\n")
    assert json.loads(lines[2])["subject"] == "w-3"  # whole, on its own line


def test_a_torn_tail_on_disk_is_reported_as_damage_not_an_error(tmp_path):
    from bim2rdt.server.audit import AuditLog

    path = tmp_path / "audit.jsonl"
    whole = json.dumps({"at": 1.0, "who": "ann", "role": "safety", "action": "identity", "subject": "w-1",
                        "why": "x", "detail": {}})
    path.write_text(whole + "\n" + whole[:30])
    entries = AuditLog(path).entries()
    assert [e["action"] for e in entries] == ["identity", "damaged"]
    assert entries[1]["detail"] == {"line": 2, "bytes": 30, "text": whole[:30]}


def test_a_failed_sync_fails_the_append(tmp_path):
    from bim2rdt.server.audit import AuditError, AuditLog

    def no_sync(fd):
        raise OSError(errno.EIO, "Input/output error")

    with pytest.raises(AuditError, match="Input/output error"):
        AuditLog(tmp_path / "audit.jsonl", sync=no_sync).append("ann", "safety", "identity", "w-1", "why")


@pytest.fixture
def flaky(tmp_path, twin, monitor):
    """(client, disk) of a server whose audit log writes through a FlakyDisk."""
    from bim2rdt.server import create_app
    from bim2rdt.server.audit import AuditLog
    from bim2rdt.server.runner import ServerThread

    disk = FlakyDisk()
    config, tokens = config_with_tokens(tmp_path, write_rate_per_minute=3)
    app = create_app(twin, monitor, identity=monitor.identity_for_server, config=config,
                     audit_log=AuditLog(tmp_path / "audit.jsonl", write=disk))
    with ServerThread(app) as server, httpx.Client(base_url=server.url, timeout=30) as http:
        http.tokens = tokens
        yield http, disk


def test_a_reveal_whose_record_cannot_be_written_is_503_and_reveals_nothing(flaky, monitor):
    client, disk = flaky
    subject = monitor.queries.session("dev-1").subject
    safety = auth(client.tokens["safety"])
    for path, body in ((f"/api/workers/{subject}/identity", REASON),
                       (f"/api/workers/{subject}/raw", {**REASON, "seconds": 1.0})):
        disk.mode, disk.keep = "short", 10
        refused = client.post(path, json=body, headers=safety)
        assert refused.status_code == 503, refused.text
        assert "anna.berg" not in refused.text and "windows" not in refused.text
    disk.mode = None
    log = client.get("/api/audit", headers=auth(client.tokens["admin"]))
    assert log.status_code == 200
    assert [e["action"] for e in log.json()] == ["damaged", "damaged"]


def test_refused_reveal_attempts_are_audited(flaky, monitor):
    client, _ = flaky
    subject = monitor.queries.session("dev-1").subject
    viewer, safety = auth(client.tokens["viewer"]), auth(client.tokens["safety"])
    assert client.post(f"/api/workers/{subject}/identity", json=REASON, headers=viewer).status_code == 403
    assert client.post("/api/workers/w-0000000000000000/identity", json=REASON, headers=safety).status_code == 404
    assert client.post("/api/workers/w-0000000000000000/raw", json=REASON, headers=safety).status_code == 404
    assert client.post(f"/api/workers/{subject}/identity", json=REASON, headers=safety).status_code == 200
    assert client.post(f"/api/workers/{subject}/identity", json=REASON, headers=safety).status_code == 429
    log = client.get("/api/audit", headers=auth(client.tokens["admin"])).json()
    assert [(e["who"], e["action"], e["subject"], e["outcome"]) for e in log] == [
        ("viewer-user", "identity", subject, "refused: role"),
        ("safety-user", "identity", "w-0000000000000000", "refused: not found"),
        ("safety-user", "raw", "w-0000000000000000", "refused: not found"),
        ("safety-user", "identity", subject, "revealed"),
        ("safety-user", "identity", subject, "refused: rate")]
    assert log[1]["why"] == REASON["reason"]


def test_restarting_the_demo_server_keeps_its_audit_log(tmp_path, site_ifc, site_model):
    """The demo's live monitor starts a new day on each start; its audit log is never removed or truncated."""
    import shutil

    from bim2rdt.config import Settings
    from bim2rdt.demo.serve import LiveServe
    from bim2rdt.server import ServerConfig
    from bim2rdt.twin import DigitalTwin

    from server_helpers import family_mesh, record_day

    shutil.copy(site_ifc, tmp_path / "site.ifc")
    with DigitalTwin.open(f"sqlite:///{tmp_path / 'twin.db'}", site_model, family_mesh=family_mesh) as twin:
        record_day(twin, site_model)
    settings = Settings(data_dir=tmp_path / "var")
    path = tmp_path / "live" / "audit.jsonl"  # where the demo keeps it (README)
    for run in range(2):
        with LiveServe(settings, ServerConfig(port=0), tmp_path, None, None, None, all_roles=True).start():
            assert path.is_file(), "the demo server keeps its audit log elsewhere: update this test"
            if run == 0:
                from bim2rdt.server.audit import AuditLog

                AuditLog(path).append("serve-safety", "safety", "identity", "w-1", "first run")
    assert "first run" in path.read_text()
