"""The API docs page (/docs, Swagger UI) over real HTTP: it references only this server (Swagger UI's files come
from the package, not a CDN), its policy forbids anything else, and in Debian's Chromium it renders the API from
this server alone."""

from __future__ import annotations

import re
from urllib.parse import urlsplit

import httpx
import pytest

from server_helpers import CHROMIUM_FLAGS, config_with_tokens

REFERENCE = re.compile(r"""\b(?:src|href|data-spec)\s*=\s*["']([^"']+)["']""", re.IGNORECASE)


@pytest.fixture
def docs_server(tmp_path):
    """The app with nothing to serve but its API description."""
    from bim2rdt.server import create_app
    from bim2rdt.server.runner import ServerThread

    config, _ = config_with_tokens(tmp_path)
    with ServerThread(create_app(config=config)) as server:
        yield server.url


def test_the_docs_page_references_only_the_servers_own_origin(docs_server):
    page = httpx.get(f"{docs_server}/docs")
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    references = REFERENCE.findall(page.text)
    assert {"/openapi.json"} < set(references), references
    references = [r for r in references if urlsplit(r).scheme != "data"]  # inline data, no request
    for reference in references:
        parts = urlsplit(reference)
        assert not parts.scheme and not parts.netloc and reference.startswith("/"), reference
    assert "http" not in page.text.lower()  # no absolute URL anywhere, not even in an inline script
    assert not re.search(r"<script(?![^>]*\bsrc=)[^>]*>", page.text), "an inline script"
    policy = page.headers["content-security-policy"]
    assert "default-src 'self'" in policy and "script-src 'self';" in policy

    files = {reference: httpx.get(f"{docs_server}{reference}") for reference in references}
    assert all(answer.status_code == 200 for answer in files.values()), {r: a.status_code for r, a in files.items()}
    scripts = [answer.text for reference, answer in files.items() if reference.endswith(".js")]
    styles = [answer for reference, answer in files.items() if reference.endswith(".css")]
    assert any("SwaggerUIBundle" in text and len(text) > 1_000_000 for text in scripts)  # Swagger UI itself
    assert styles and all(a.headers["content-type"].startswith("text/css") and ".swagger-ui" in a.text for a in styles)
    assert any("validatorUrl: null" in text for text in scripts)  # else it sends the spec's URL to swagger.io


def test_redoc_is_not_served_because_it_loads_from_a_cdn(docs_server):
    assert httpx.get(f"{docs_server}/redoc").status_code == 404


def test_swagger_ui_renders_the_api_in_chromium_from_this_server_alone(docs_server, chromium):
    from playwright.sync_api import expect, sync_playwright

    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=chromium, args=CHROMIUM_FLAGS)
        page = browser.new_page()
        requested, problems = [], []
        page.on("request", lambda request: requested.append(request.url))
        page.on("pageerror", lambda error: problems.append(str(error)))
        page.on("console", lambda message: problems.append(message.text) if message.type == "error" else None)
        page.goto(f"{docs_server}/docs")
        expect(page.locator(".swagger-ui .info .title")).to_contain_text("bim2rdt", timeout=20_000)
        expect(page.locator(".opblock-summary-path[data-path='/api/health']")).to_have_count(1)
        browser.close()
    assert all(u.startswith(docs_server) or u.startswith("data:") for u in requested), requested
    assert not problems, problems  # a blocked file or a Content-Security-Policy violation shows here
