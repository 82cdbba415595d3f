"""The takes panel in headless Chromium against the real app (simulator pipeline): record a take with
a protocol, see its prompt and progress, and find it complete in the list."""

from __future__ import annotations

from pathlib import Path

import httpx
import pytest

from tests.app.conftest import Served, make_settings

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

CHROMIUM = "/usr/bin/chromium"
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking"]


def test_record_a_take_from_the_dashboard(tmp_path: Path, artifacts_dir: Path) -> None:
    from playwright.sync_api import expect, sync_playwright

    if not Path(CHROMIUM).exists():
        pytest.fail(f"{CHROMIUM} missing: apt-get install -y chromium chromium-driver")
    with Served(make_settings(tmp_path)) as served, sync_playwright() as pw:
        served.wait_status(lambda st: st["state"] == "running" and st["navigator"] is not None, 60)
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        page = browser.new_page(viewport={"width": 1400, "height": 1000})
        errors: list[str] = []
        page.on("pageerror", lambda exc: errors.append(str(exc)))
        try:
            page.goto(served.base)
            panel = page.locator("#recording-panel")
            expect(panel.locator("#take-protocol option[value='four-actions']")).to_be_attached(
                timeout=20_000
            )
            panel.locator("#take-participant").fill("PW1")
            panel.locator("#take-protocol").select_option("four-actions")
            panel.locator("#take-duration").fill("3")
            panel.locator("#take-margin").fill("0.3")
            panel.locator("#take-start").click()
            expect(panel.locator("#take-state")).to_contain_text("recording take 1", timeout=10_000)
            expect(panel.locator("#take-state")).to_contain_text("Stand still")
            panel.screenshot(path=str(artifacts_dir / "takes-recording.png"))
            row = panel.locator("#take-table tr[data-take-id='1']")
            expect(row).to_have_attribute("data-status", "complete", timeout=30_000)
            expect(row).to_contain_text("PW1")
            expect(row).to_contain_text("four actions")
            panel.screenshot(path=str(artifacts_dir / "takes-panel.png"))
            # a bad margin: one clear message, no take stored
            panel.locator("#take-margin").fill("9")
            panel.locator("#take-start").click()
            expect(page.locator("#toast")).to_contain_text("margin_s must be", timeout=10_000)
        finally:
            browser.close()
        takes = httpx.get(f"{served.base}/api/v1/takes").json()
        assert [(t["participant_code"], t["status"], t["margin_s"]) for t in takes] == [
            ("PW1", "complete", 0.3)
        ]
        assert not errors, errors
