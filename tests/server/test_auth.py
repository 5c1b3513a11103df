"""Roles and privacy over real HTTP: the auth matrix (every role x every API endpoint), 401/403 that reveal
nothing, reveals written to the audit log, and the request limits on the write endpoints."""

from __future__ import annotations

import httpx
import pytest

from server_helpers import auth, config_with_tokens

REASON = {"reason": "HAV health surveillance referral"}
ROLES = ("viewer", "safety", "admin")


def endpoints(app):
    """(method, path template, allowed roles) of every /api operation but health, from the app's OpenAPI
    document: a new endpoint joins the matrix without editing this test."""
    out = []
    for path, operations in app.openapi()["paths"].items():
        if not path.startswith("/api/") or path == "/api/health":
            continue
        for method, operation in operations.items():
            out.append((method.upper(), path, set(operation.get("x-roles", ()))))
    return out


def call(client, method, template, ids, headers):
    path = template.format(**ids)
    if path.endswith("/stream"):
        with client.stream(method, path, headers=headers) as response:
            return response.status_code
    return client.request(method, path, headers=headers, json=REASON if method == "POST" else None).status_code


@pytest.fixture
def ids(client, twin):
    subject = client.get("/api/workers", headers=auth(client.tokens["viewer"])).json()[0]["subject"]
    return {"global_id": twin.ids["moved"], "subject": subject}


def test_the_matrix_covers_the_api(served):
    paths = {path for _, path, _ in endpoints(served[2])}
    assert {"/api/elements", "/api/workers", "/api/stream", "/api/audit", "/api/workers/{subject}/identity",
            "/api/workers/{subject}/raw", "/api/state", "/api/exports/twin.bcf", "/api/model.glb"} <= paths


def test_auth_matrix_every_role_on_every_endpoint(client, served, ids):
    wrong = "x" * 43
    for method, template, allowed in endpoints(served[2]):
        assert allowed, f"{method} {template} declares no roles"
        assert call(client, method, template, ids, {}) == 401, (method, template, "no token")
        assert call(client, method, template, ids, auth(wrong)) == 401, (method, template, "wrong token")
        assert call(client, method, template, ids, {"Authorization": "Basic dXNlcjpwYXNz"}) == 401
        for role in ROLES:
            status = call(client, method, template, ids, auth(client.tokens[role]))
            if role in allowed:
                assert status == 200, (method, template, role, status)
            else:
                assert status == 403, (method, template, role, status)


def test_reveals_are_for_the_safety_officer_only(client, ids):
    for role, expected in (("viewer", 403), ("admin", 403)):
        response = client.post(f"/api/workers/{ids['subject']}/identity", json=REASON,
                               headers=auth(client.tokens[role]))
        assert response.status_code == expected
    response = client.get("/api/audit", headers=auth(client.tokens["safety"]))
    assert response.status_code == 403


def test_refusals_do_not_say_whether_the_thing_exists(client, ids):
    viewer = auth(client.tokens["viewer"])
    for subject in (ids["subject"], "w-0000000000000000"):
        denied = client.post(f"/api/workers/{subject}/identity", json=REASON, headers=viewer)
        assert (denied.status_code, denied.json()) == (403, {"detail": "your role may not use this endpoint"})
        # a malformed body does not get past the role check either
        assert client.post(f"/api/workers/{subject}/identity", content=b"{", headers=viewer).status_code == 403
    for path in ("/api/elements/NOPE", "/api/no-such-endpoint", f"/api/elements/{ids['global_id']}"):
        anonymous = client.get(path)
        assert (anonymous.status_code, anonymous.json()) == (401, {"detail": "missing or invalid bearer token"})
    assert client.get("/api/no-such-endpoint", headers=viewer).status_code == 404


def test_an_identity_reveal_is_audited_with_who_when_which_and_why(client, ids):
    safety = auth(client.tokens["safety"])
    response = client.post(f"/api/workers/{ids['subject']}/identity", json=REASON, headers=safety)
    assert response.json() == {"subject": ids["subject"], "worker": "anna.berg"}
    raw = client.post(f"/api/workers/{ids['subject']}/raw", json={**REASON, "seconds": 2.0}, headers=safety).json()
    window = raw["windows"][0]
    assert window["fs"] == 800.0 and len(window["samples"]) == 1600 and len(window["samples"][0]) == 3
    log = client.get("/api/audit", headers=auth(client.tokens["admin"])).json()
    assert [(e["who"], e["role"], e["action"], e["subject"], e["why"]) for e in log] == [
        ("safety-user", "safety", "identity", ids["subject"], REASON["reason"]),
        ("safety-user", "safety", "raw", ids["subject"], REASON["reason"])]
    assert log[0]["at"] <= log[1]["at"]


def test_a_reveal_needs_a_reason_and_its_window_is_cut_to_the_limit(client, ids):
    safety = auth(client.tokens["safety"])
    assert client.post(f"/api/workers/{ids['subject']}/identity", json={}, headers=safety).status_code == 422
    assert client.get("/api/audit", headers=auth(client.tokens["admin"])).json() == []
    long = client.post(f"/api/workers/{ids['subject']}/raw", json={**REASON, "seconds": 60}, headers=safety).json()
    assert long["seconds"] == 10.0 and len(long["windows"][0]["samples"]) == 8000  # the last 10 s kept, 800 Hz


def test_a_pseudonym_without_identity_is_404_for_the_safety_officer(client):
    response = client.post("/api/workers/w-0000000000000000/identity", json=REASON,
                           headers=auth(client.tokens["safety"]))
    assert response.status_code == 404


@pytest.fixture
def limited(tmp_path, twin, monitor):
    from bim2rdt.server import create_app
    from bim2rdt.server.runner import ServerThread

    config, tokens = config_with_tokens(tmp_path, write_rate_per_minute=3, max_body_bytes=1024)
    app = create_app(twin, monitor, identity=monitor.identity_for_server, config=config)
    with ServerThread(app) as server, httpx.Client(base_url=server.url, timeout=30) as http:
        http.tokens = tokens
        yield http


def test_write_endpoints_are_rate_limited_per_token(limited, monitor):
    subject = monitor.queries.session("dev-1").subject
    safety = auth(limited.tokens["safety"])
    codes = [limited.post(f"/api/workers/{subject}/identity", json=REASON, headers=safety).status_code
             for _ in range(4)]
    assert codes == [200, 200, 200, 429]
    refused = limited.post(f"/api/workers/{subject}/identity", json=REASON, headers=safety)
    assert int(refused.headers["retry-after"]) >= 1
    outcomes = [e["outcome"] for e in limited.get("/api/audit", headers=auth(limited.tokens["admin"])).json()]
    assert outcomes == ["revealed"] * 3 + ["refused: rate"]  # the second 429 within a minute is not written
    # reads are not limited
    assert all(limited.get("/api/workers", headers=safety).status_code == 200 for _ in range(6))


def test_bodies_over_the_limit_are_refused_whole_or_chunked(limited, monitor):
    subject = monitor.queries.session("dev-1").subject
    safety = auth(limited.tokens["safety"])
    big = {"reason": "x" * 2000}
    assert limited.post(f"/api/workers/{subject}/identity", json=big, headers=safety).status_code == 413
    # by its Content-Length, even where the endpoint would never read a body
    assert limited.request("GET", "/api/workers", content=b"x" * 2000, headers=safety).status_code == 413

    def chunks():
        yield b'{"reason": "'
        for _ in range(40):
            yield b"y" * 100
        yield b'"}'

    response = limited.post(f"/api/workers/{subject}/identity", content=chunks(),
                            headers={**safety, "Content-Type": "application/json"})
    assert response.status_code == 413
    assert limited.get("/api/audit", headers=auth(limited.tokens["admin"])).json() == []
