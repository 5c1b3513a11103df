"""schemathesis against the published OpenAPI document, over real HTTP: every operation, a bounded number of
generated cases each, with a token of a role the operation declares; responses must match the schema (status
codes, content types, bodies) and no case may make the server fail."""

from __future__ import annotations

import httpx
import pytest
from hypothesis import HealthCheck, given, settings

from server_helpers import auth, config_with_tokens

CASES = 8
"""Generated cases per operation (bounded: the suite's time is shared)."""
SKIPPED = {"/api/stream"}
"""The live stream never ends; test_stream.py covers it."""


@pytest.fixture
def schema_server(tmp_path, twin, monitor):
    from bim2rdt.server import create_app
    from bim2rdt.server.runner import ServerThread

    config, tokens = config_with_tokens(tmp_path, write_rate_per_minute=10_000)
    app = create_app(twin, monitor, identity=monitor.identity_for_server, config=config)
    with ServerThread(app) as server:
        yield server.url, tokens


def test_the_api_conforms_to_its_openapi_document(schema_server):
    import schemathesis

    url, tokens = schema_server
    document = httpx.get(f"{url}/openapi.json").json()
    assert document["components"]["securitySchemes"]["HTTPBearer"]["scheme"] == "bearer"
    schema = schemathesis.openapi.from_url(f"{url}/openapi.json")
    tested = []
    for result in schema.get_all_operations():
        operation = result.ok()
        if operation.path in SKIPPED:
            continue
        roles = document["paths"][operation.path][operation.method.lower()].get("x-roles", ["viewer"])
        headers = auth(tokens[roles[0]])
        cases = 1 if "exports" in operation.path else CASES

        @given(case=operation.as_strategy())
        @settings(max_examples=cases, deadline=None, database=None, derandomize=True,
                  suppress_health_check=list(HealthCheck))
        def check(case):
            case.call_and_validate(base_url=url, headers=headers)

        check()
        tested.append(f"{operation.method.upper()} {operation.path}")
    assert len(tested) >= 15, tested


NON_FINITE = ("Infinity", "-Infinity", "NaN", "1e400")
"""What Python's JSON parser (the server's) reads as a float that is not finite."""


def test_non_finite_numbers_in_a_body_are_422_without_echoing_them(schema_server):
    """JSON has no Infinity or NaN, but the server's parser reads them (and 1e400 is inf): every POST operation,
    with each in each field of its body, answers 422 (validated against the schema by schemathesis) and never
    sends the value back."""
    import schemathesis

    url, tokens = schema_server
    document = httpx.get(f"{url}/openapi.json").json()
    subject = httpx.get(f"{url}/api/workers", headers=auth(tokens["viewer"])).json()[0]["subject"]
    schema = schemathesis.openapi.from_url(f"{url}/openapi.json")
    posts = [r.ok() for r in schema.get_all_operations() if r.ok().method.upper() == "POST"]
    assert len(posts) >= 2
    for operation in posts:
        roles = document["paths"][operation.path]["post"]["x-roles"]
        fields = ("reason", "start", "seconds") if operation.path.endswith("/raw") else ("reason",)
        for field in fields:
            for number in NON_FINITE:
                others = ", ".join(f'"{f}": 1.5' for f in fields if f not in (field, "reason"))
                reason = '"reason": "HAV referral"' if field != "reason" else f'"reason": {number}'
                value = f', "{field}": {number}' if field != "reason" else ""
                body = ("{" + reason + value + (", " + others if others else "") + "}").encode()
                case = operation.Case(path_parameters={"subject": subject}, body=body, media_type="application/json")
                response = case.call_and_validate(base_url=url, headers=auth(tokens[roles[0]]))
                assert response.status_code == 422, (operation.path, body, response.text)
                assert not any(word in response.text for word in ("Infinity", "NaN", "inf", "1e400")), response.text
