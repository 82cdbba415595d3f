"""The hold on the dashboard, in headless Chromium against the real app (the simulator's stepping
user, the real recogniser, a real UDP socket as the workstation). A controller session started
before the pipeline holds by itself (the notice says so): once the pipeline runs the walls get only
still while the notice shows what the recogniser says; the session's stop releases it and the walls
move; the button holds again (the operator's hold) and the key H releases it; the session's summary
counts the hold. Screenshots are test artifacts."""

from __future__ import annotations

import re
from pathlib import Path

import httpx
import pytest

from tests.app.conftest import Served, make_settings
from tests.browser import CHROMIUM, chromium, watched_page
from tests.datagrams import DatagramRecorder
from tests.waiting import HTTP_TIMEOUT_S, wait_until

pytestmark = [pytest.mark.e2e, pytest.mark.slow]


def test_a_controller_session_holds_then_its_stop_the_button_and_the_key_h(
    tmp_path: Path, artifacts_dir: Path
) -> None:
    from playwright.sync_api import expect, sync_playwright

    if not Path(CHROMIUM).exists():
        pytest.fail(f"{CHROMIUM} missing: apt-get install -y chromium chromium-driver")
    rx = DatagramRecorder()
    settings = make_settings(tmp_path).model_copy(update={"workstations": [f"127.0.0.1:{rx.port}"]})
    try:
        with Served(settings, autostart=None) as served, sync_playwright() as pw, chromium(pw) as browser:
            errors: list[str] = []
            page = watched_page(browser, errors, viewport={"width": 1600, "height": 1000})
            api = f"{served.base}/api/v1"
            pid = httpx.post(f"{api}/participants", json={"code": "HOLD2"},
                             timeout=HTTP_TIMEOUT_S).json()["id"]
            sid = httpx.post(f"{api}/sessions", json={"participant_id": pid, "condition": "CC"},
                             timeout=HTTP_TIMEOUT_S).json()["id"]
            page.goto(served.base)
            row = page.locator(f'#session-table tbody tr[data-session-id="{sid}"]')
            button, notice = page.locator("#hold-toggle"), page.locator("#hold-notice")
            expect(page.locator("#ws-state")).to_have_text("live: open", timeout=30_000)
            expect(notice).to_be_hidden()
            row.locator("button.session-start").click()  # a controller session: held while it runs
            expect(button).to_have_attribute("aria-pressed", "true", timeout=30_000)
            expect(button).to_have_text("Release navigation")
            expect(notice).to_be_visible()
            expect(notice).to_contain_text("held for the controller session (CC) until it stops")
            assert httpx.get(f"{api}/navigation/hold", timeout=HTTP_TIMEOUT_S).json()["held"]

            page.locator("#pipeline-start").click()  # nothing ran yet: held from its first datagram
            expect(page.locator("#hold-recognised")).to_have_text(re.compile("forward|left|right"),
                                                                    timeout=120_000)
            notice.screenshot(path=str(artifacts_dir / "hold-notice.png"))
            wait_until(lambda: len(rx.of_type("locomotion")) > 60 or None, "a second of the held stream")
            before_stop = len(rx.got)
            row.locator("button.session-stop").click()
            expect(button).to_have_attribute("aria-pressed", "false", timeout=30_000)
            expect(notice).to_be_hidden()
            released = len(rx.got)
            wait_until(lambda: any(m["type"] == "locomotion" and m["action"] != "still"
                                   for _, m in rx.got[released:]) or None, "the walls move again")

            button.click()  # the operator's own hold
            expect(button).to_have_attribute("aria-pressed", "true", timeout=30_000)
            expect(notice).to_be_visible()
            expect(notice).not_to_contain_text("controller session")
            page.locator("body").click(position={"x": 5, "y": 500})  # the focus off the buttons
            page.keyboard.press("h")
            expect(button).to_have_attribute("aria-pressed", "false", timeout=30_000)
            expect(notice).to_be_hidden()
            hold = httpx.get(f"{api}/navigation/hold", timeout=HTTP_TIMEOUT_S).json()
            assert hold == {"held": False, "changed": False}, hold
            page.locator(f'#session-table tbody tr[data-session-id="{sid}"] button.session-select').click()
            summary = page.locator("#summary-list")
            expect(summary).to_contain_text("navigation held", timeout=30_000)
            expect(summary).to_contain_text("(1 hold)", timeout=30_000)
            assert errors == [], errors
    finally:
        rx.close()
    held = [m for _, m in rx.got[:before_stop] if m["type"] == "locomotion"]
    assert held and {m["action"] for m in held} == {"still"}, {m["action"] for m in held}
