"""Headless Chromium for the browser tests: one launch with the README's flags, and pages whose
JavaScript errors are collected (each test asserts there were none). Playwright itself is imported
by the tests, inside the test functions."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from playwright.sync_api import Browser, Page, Playwright

CHROMIUM = "/usr/bin/chromium"
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking"]


@contextmanager
def chromium(pw: Playwright) -> Iterator[Browser]:
    """The system's Chromium, closed on the way out whatever happened."""
    browser = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
    try:
        yield browser
    finally:
        browser.close()


def watched_page(browser: Browser, errors: list[str], label: str = "", **options: Any) -> Page:
    """A new page (``options`` as for ``Browser.new_page``) whose uncaught JavaScript errors are
    appended to ``errors`` (prefixed with ``label`` when given)."""
    page = browser.new_page(**options)
    page.on("pageerror", lambda exc: errors.append(f"{label}: {exc}" if label else str(exc)))
    return page
