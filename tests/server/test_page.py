"""The page in a real headless Chromium (Debian's, driven by Playwright): it loads from the server alone, draws
the plan, the 3-D twin, the gauges and the tables, and shows the warning banner the moment a simulated worker
crosses the EAV, then the alarm at the ELV. Screenshots go to the test's folder (and to $BIM2RDT_SCREENSHOTS)."""

from __future__ import annotations

import os
import shutil
import time
from pathlib import Path

import pytest

import httpx

from bim2rdt.bus import accel_topic

from server_helpers import CHROMIUM_FLAGS, SITE_SECRET, T_TWIN, auth, config_with_tokens, feed, today_since, vibration

A_HV = 30.0
"""m/s^2: a heavy breaker, so the EAV (180,000 m^2/s^3 of energy) comes after 200 s of samples."""



@pytest.fixture
def page_server(tmp_path, twin):
    """The app over the recorded twin and a monitor whose worker is at 90 % of the EAV's energy."""
    from bim2rdt.safety import HavMonitor, IdentityMap, MonitorConfig
    from bim2rdt.server import create_app
    from bim2rdt.server.runner import ServerThread

    monitor = HavMonitor(tmp_path / "hav", SITE_SECRET, config=MonitorConfig(site="test"))
    monitor.start_session("dev-1", "carla.diaz", "breaker", zone="Work zone A")
    start = today_since(3600, 960)  # the feeds below span 920 s from it
    feed(monitor, vibration("dev-1", 180.0, A_HV, start))
    identity = IdentityMap(tmp_path / "hav" / "private" / "identity.sqlite", role="safety")
    config, tokens = config_with_tokens(tmp_path)
    app = create_app(twin, monitor, identity=identity, config=config)
    with ServerThread(app) as server:
        yield server.url, tokens, monitor, start
    identity.close()
    monitor.close()


@pytest.mark.timeout(1800)  # run in the first 16 min of a UTC day, page_server waits for today's 920 s of samples
def test_the_page_shows_the_twin_and_warns_the_moment_a_worker_crosses_the_eav(page_server, chromium, tmp_path):
    from playwright.sync_api import expect, sync_playwright

    url, tokens, monitor, start = page_server
    shots = []
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=chromium, args=CHROMIUM_FLAGS)
        page = browser.new_page(viewport={"width": 1400, "height": 1250})
        requested, errors = [], []
        page.on("request", lambda request: requested.append(request.url))
        page.on("pageerror", lambda error: errors.append(str(error)))
        page.goto(f"{url}/#token={tokens['viewer']}")

        expect(page.locator("#connection")).to_have_text("live", timeout=20_000)
        expect(page.locator("body")).to_have_attribute("data-model", "loaded", timeout=30_000)
        gauge = page.locator(".gauge").first
        expect(gauge).to_have_attribute("data-risk", "below_eav", timeout=10_000)
        expect(page.locator("#banner")).to_be_hidden()
        assert page.locator("#plan polygon.element").count() >= 4
        assert page.locator("#plan polyline.path").count() == 1
        assert page.locator("#deviations tbody tr").count() == 4
        assert "#token" not in page.url  # the token leaves the address bar at once
        shots.append(_shot(page, tmp_path / "page-below-eav.png"))

        expect(page.locator("#counts")).to_contain_text("1 deviating")
        page.locator("#at").fill(str(int(T_TWIN + 10)))  # the twin before the moved object's record
        expect(page.locator("#deviations tbody tr")).to_have_count(1)
        expect(page.locator("#counts")).to_have_text("1 as planned")  # the header follows the time bar
        expect(page.locator("#at-label")).to_contain_text("UTC")
        assert page.locator("#plan polyline.path").count() == 0  # one station: no path yet
        assert page.locator("#plan circle.station").count() == 1
        page.locator("#at-now").click()
        expect(page.locator("#deviations tbody tr")).to_have_count(4)
        expect(page.locator("#counts")).to_contain_text("1 deviating")

        feed(monitor, vibration("dev-1", 40.0, A_HV, start + 180.0, seq0=360))  # crosses the EAV
        crossed = time.time()
        banner = page.locator("#banner")
        expect(banner).to_have_attribute("data-level", "warning", timeout=5_000)
        expect(banner).to_be_visible()
        shown = time.time() - crossed
        expect(banner).to_contain_text(monitor.queries.session("dev-1").subject)
        expect(gauge).to_have_attribute("data-risk", "above_eav")
        expect(page.locator("#timeline li[data-kind='hav.eav_reached']")).to_have_count(1)
        shots.append(_shot(page, tmp_path / "page-eav-warning.png"))

        page.locator("#deviations tbody tr").first.click()
        expect(page.locator("#detail")).to_contain_text("History")
        expect(page.locator("#detail")).to_contain_text("deviating")

        feed(monitor, vibration("dev-1", 700.0, A_HV, start + 220.0, seq0=440))  # on to the ELV
        expect(banner).to_have_attribute("data-level", "alarm", timeout=5_000)
        expect(banner).to_be_visible()
        expect(gauge).to_have_attribute("data-risk", "above_elv")
        shots.append(_shot(page, tmp_path / "page-elv-alarm.png"))
        assert page.locator(".gauge .reveal").count() == 0  # a viewer cannot reveal

        assert gauge.locator(".refused").count() == 0
        for payload in (b"HAV1 garbage", b"not an accel batch"):  # malformed: refused, counted for the device
            monitor.ingest_payload(accel_topic("test", "dev-1"), payload)
        expect(gauge.locator("[data-device='dev-1'] .refused")).to_have_text(" · 2 refused", timeout=5_000)

        officer = browser.new_page(viewport={"width": 1400, "height": 900})
        officer.on("dialog", lambda dialog: dialog.accept("HAV health surveillance referral"))
        officer.goto(f"{url}/#token={tokens['safety']}")
        officer.locator(".gauge .reveal").first.click()
        expect(officer.locator(".gauge .name").first).to_have_text("carla.diaz")
        officer.wait_for_timeout(1500)  # the next exposure update redraws the gauges: the name stays
        expect(officer.locator(".gauge .name").first).to_have_text("carla.diaz")
        browser.close()

    assert shown < 2.0, f"the banner took {shown:.2f} s"
    assert not errors, errors
    assert all(u.startswith(url) or u.startswith(("data:", "blob:")) for u in requested), requested
    audit = httpx.get(f"{url}/api/audit", headers=auth(tokens["admin"])).json()
    assert [(e["who"], e["action"], e["why"]) for e in audit] == [
        ("safety-user", "identity", "HAV health surveillance referral")]
    _keep(shots)


def _shot(page, path: Path) -> Path:
    page.screenshot(path=str(path), full_page=True)
    return path


def _keep(shots: list[Path]) -> None:
    folder = os.environ.get("BIM2RDT_SCREENSHOTS")
    if folder:
        Path(folder).mkdir(parents=True, exist_ok=True)
        for shot in shots:
            shutil.copy(shot, Path(folder) / shot.name)
