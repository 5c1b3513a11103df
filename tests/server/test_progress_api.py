"""GET /api/progress and the page's progress card: each task of the site's schedule with planned %, observed %
and status from the twin, the S-curve, and the structure's states for the 3-D view (in a headless Chromium)."""

from __future__ import annotations

from server_helpers import CHROMIUM_FLAGS, T_TWIN, auth


def test_progress_follows_the_twin_now_and_at_a_past_time(client):
    answer = client.get("/api/progress", headers=auth(client.tokens["viewer"]))
    assert answer.status_code == 200, answer.text
    record = answer.json()
    tasks = {t["identification"]: t for t in record["progress"]["tasks"]}
    assert len(tasks) == 11 and record["groups"] == []
    cones = tasks["T.1"]  # one cone as planned, one moved, one missing: two of three built, months early
    assert cones["products"] == {"as planned": 1, "deviating": 1, "not built": 1, "not observed": 0}
    assert cones["observed_percent"] == 66.7 and cones["planned_percent"] == 0.0 and cones["status"] == "ahead"
    assert tasks["S.5"]["status"] == "unknown" and len(record["structure"]) == 15
    assert set(record["structure"].values()) == {"not observed"} and record["curve"]
    before = client.get("/api/progress", params={"at": T_TWIN + 10}, headers=auth(client.tokens["viewer"])).json()
    early = {t["identification"]: t for t in before["progress"]["tasks"]}["T.1"]
    assert early["products"]["as planned"] == 1 and early["products"]["not observed"] == 2
    assert client.get("/api/progress").status_code == 401


def test_the_page_shows_the_task_table_by_status_and_the_s_curve(served, chromium, tmp_path):
    from playwright.sync_api import expect, sync_playwright

    url, tokens, _ = served
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=chromium, args=CHROMIUM_FLAGS)
        page = browser.new_page(viewport={"width": 1400, "height": 1600})
        errors = []
        page.on("pageerror", lambda error: errors.append(str(error)))
        page.goto(f"{url}/#token={tokens['viewer']}")
        expect(page.locator("body")).to_have_attribute("data-model", "loaded", timeout=30_000)
        expect(page.locator("#progress-card")).to_be_visible(timeout=20_000)
        expect(page.locator("#tasks tbody tr")).to_have_count(11)
        expect(page.locator("#tasks tr[data-status='ahead']")).to_have_count(1)
        assert page.locator("#s-curve path.curve-planned").get_attribute("d").startswith("M")
        page.locator("#built-view").check()
        page.wait_for_timeout(300)
        page.screenshot(path=str(tmp_path / "progress.png"), full_page=True)
        browser.close()
    assert not errors, errors
