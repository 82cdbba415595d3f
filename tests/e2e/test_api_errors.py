"""The dashboard's API client in headless Chromium: an error answer that is not JSON (a proxy's
HTML page) still becomes an ``ApiError`` with the status, never a JSON ``SyntaxError``."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.app.conftest import Served, make_settings
from tests.browser import CHROMIUM, chromium

pytestmark = [pytest.mark.e2e, pytest.mark.slow]


CALL = """async () => {
  const m = await import('/js/api.js');
  try { await m.get('/participants'); return {thrown: false}; }
  catch (e) { return {thrown: true, apiError: e instanceof m.ApiError, status: e.status, message: e.message,
                      name: e.constructor.name}; }
}"""


def test_a_non_json_error_answer_is_an_api_error(tmp_path: Path) -> None:
    from playwright.sync_api import sync_playwright

    if not Path(CHROMIUM).exists():
        pytest.fail(f"{CHROMIUM} missing: apt-get install -y chromium chromium-driver")
    with (
        Served(make_settings(tmp_path), autostart=None) as served,
        sync_playwright() as pw,
        chromium(pw) as browser,
    ):
        page = browser.new_page()
        page.goto(f"{served.base}/")
        page.route(
            "**/api/v1/participants",
            lambda route: route.fulfill(
                status=502,
                content_type="text/html",
                body="<html><body><h1>502 Bad Gateway</h1></body></html>",
            ),
        )
        got = page.evaluate(CALL)
        assert got["thrown"] and got["apiError"], got
        assert got["status"] == 502 and got["message"], got
        page.unroute("**/api/v1/participants")
        assert page.evaluate(CALL) == {"thrown": False}, "the real answer is JSON and passes"
