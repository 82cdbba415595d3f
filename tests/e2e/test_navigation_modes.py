"""The navigation modes on the dashboard, in headless Chromium against the real app (simulator with
three stepping people, real recogniser): the mode buttons, each person's own command, confidence
and strip, the chosen people of group mode and the room's command. Screenshots are test artifacts."""

from __future__ import annotations

import contextlib
import re
from dataclasses import replace
from pathlib import Path

import httpx
import pytest

from tests.app.conftest import Served, make_settings
from tests.browser import CHROMIUM, chromium, watched_page
from tests.waiting import HTTP_TIMEOUT_S

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

ACTIONS = r"(still|forward|left|right) \d+ %"


def test_the_people_list_follows_the_navigation_mode(tmp_path: Path, artifacts_dir: Path) -> None:
    from playwright.sync_api import TimeoutError as PlaywrightTimeout
    from playwright.sync_api import expect, sync_playwright

    if not Path(CHROMIUM).exists():
        pytest.fail(f"{CHROMIUM} missing: apt-get install -y chromium chromium-driver")
    s = make_settings(tmp_path)
    settings = s.model_copy(update={"sim": replace(s.sim, people=3, bystanders=0)})
    with Served(settings) as served, sync_playwright() as pw:
        served.wait_status(lambda st: len(st["people"]) == 3)
        with chromium(pw) as browser:
            errors: list[str] = []
            page = watched_page(browser, errors, viewport={"width": 1600, "height": 1000})
            page.goto(served.base)
            panel = page.locator("#people-panel")
            rows = page.locator("#people-list li")
            expect(rows).to_have_count(3, timeout=30_000)
            expect(panel.locator(".mode.active")).to_have_text("Single")
            panel.locator(".mode[data-mode=each]").click()
            expect(panel.locator(".mode.active")).to_have_text("Each", timeout=30_000)
            for i in range(3):  # every person has a command of their own, with its confidence
                expect(rows.nth(i).locator(".person-command")).to_have_text(re.compile(ACTIONS),
                                                                     timeout=30_000)
            # every person's strip fills with their own commands (a person the tracker lost for a
            # moment starts a new strip, so wait for the outcome rather than a fixed few seconds)
            counts = ("() => [...document.querySelectorAll('#people-list .commands')]"
                      ".map((s) => s.querySelectorAll('.tick:not(.none)').length)")
            with contextlib.suppress(PlaywrightTimeout):  # the assertion below says what they held
                page.wait_for_function(f"() => {{ const t = ({counts})(); return t.length === 3 && "
                                       "Math.min(...t) > 5; }", timeout=60_000)
            ticks = page.evaluate(counts)
            assert len(ticks) == 3 and min(ticks) > 5, f"each person's strip fills: {ticks}"
            panel.screenshot(path=str(artifacts_dir / "navigation-each.png"))

            ids = [int(rows.nth(i).get_attribute("data-user-id") or -1) for i in range(2)]
            for i in range(2):
                rows.nth(i).locator(".chosen").check()
            panel.locator(".mode[data-mode=group]").click()
            expect(panel.locator(".mode.active")).to_have_text("Group", timeout=30_000)
            expect(page.locator("#navigation-group")).to_contain_text("room:", timeout=30_000)
            expect(rows.nth(2).locator(".person-command")).to_have_text("no command", timeout=30_000)
            status = httpx.get(f"{served.base}/api/v1/status", timeout=HTTP_TIMEOUT_S).json()
            chosen = sorted(status["navigation"]["chosen"])
            assert chosen == sorted(ids), (status["navigation"], status["people"])
            panel.screenshot(path=str(artifacts_dir / "navigation-group.png"))
            missing = page.locator("#navigation-missing")
            expect(missing).to_be_hidden()

            # a new run numbers people afresh, past the ids of the last: the kept choice is nobody
            r = httpx.post(f"{served.base}/api/v1/pipeline/start", json={"source": "simulator"},
                           timeout=HTTP_TIMEOUT_S)
            assert r.status_code == 200, r.text
            expect(missing).to_have_text(f"Chosen but not tracked now: {', '.join(map(str, sorted(ids)))} "
                                         "(nobody navigates). Tick the people and choose the mode again.",
                                         timeout=30_000)
            expect(panel.locator(".mode.active")).to_have_text("Group")
            expect(rows).to_have_count(3, timeout=30_000)
            new_ids = [int(rows.nth(i).get_attribute("data-user-id") or -1) for i in range(3)]
            assert min(new_ids) > max(ids), (ids, new_ids)
            for i in range(3):
                expect(rows.nth(i).locator(".person-command")).to_have_text("no command", timeout=30_000)
            panel.screenshot(path=str(artifacts_dir / "navigation-kept-choice.png"))

            panel.locator(".mode[data-mode=single]").click()
            expect(panel.locator(".mode.active")).to_have_text("Single", timeout=30_000)
            expect(page.locator("#navigation-group")).to_have_text("")
            expect(missing).to_be_hidden()
        assert not errors, errors
