"""The step strip under the command history, in headless Chromium against the real app (simulated
user, real recogniser with the stepping-bout gate): both feet's contact, the gate's verdict and the
newest step's displacement in words."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from tests.app.conftest import Served, make_settings
from tests.browser import CHROMIUM, chromium, watched_page

pytestmark = [pytest.mark.e2e, pytest.mark.slow]


def test_the_step_strip_shows_feet_gate_and_the_newest_step(tmp_path: Path, artifacts_dir: Path) -> None:
    from playwright.sync_api import expect, sync_playwright

    if not Path(CHROMIUM).exists():
        pytest.fail(f"{CHROMIUM} missing: apt-get install -y chromium chromium-driver")
    s = make_settings(tmp_path)
    settings = s.model_copy(update={"recognition": replace(s.recognition, gate=True)})
    with Served(settings) as served, sync_playwright() as pw:
        status = served.wait_status(lambda st: bool(st.get("action") and st["action"].get("steps")))
        steps = status["action"]["steps"]
        assert [f["foot"] for f in steps["feet"]] == ["left", "right"] and steps["gate"] is not None
        with chromium(pw) as browser:
            errors: list[str] = []
            page = watched_page(browser, errors, viewport={"width": 1400, "height": 1000})
            page.goto(served.base)
            strip = page.locator("#step-strip-slot")
            expect(strip.locator("#steps-left .tick.planted").first).to_be_attached(timeout=20_000)
            expect(strip.locator("#steps-right .tick.planted").first).to_be_attached(timeout=20_000)
            expect(strip.locator("#steps-gate .tick.gate").first).to_be_attached(timeout=20_000)
            # the simulated user steps: a swinging foot and a stepping gate show up on the strip
            expect(strip.locator(".tick.swing").first).to_be_attached(timeout=40_000)
            expect(strip.locator("#steps-gate .tick.stepping").first).to_be_attached(timeout=40_000)
            expect(strip.locator("#steps-detail")).to_contain_text("gate:")
            expect(strip.locator("#steps-detail")).to_contain_text("newest step:")
            expect(strip.locator("#steps-detail")).to_contain_text("leg raised")  # the kick rule's measure
            page.wait_for_timeout(3000)  # a few seconds of strip for the screenshot
            counts = page.evaluate(
                "() => ['steps-left', 'steps-right', 'steps-gate']"
                ".map((id) => document.getElementById(id).childElementCount)"
            )
            assert len(set(counts)) == 1 and counts[0] > 20, f"the rows share one time axis: {counts}"
            page.locator("#action-panel").screenshot(path=str(artifacts_dir / "step-strip.png"))
        assert not errors, errors
