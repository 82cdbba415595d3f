"""The questionnaire form and the analysis panel in headless Chromium against the real app."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

CHROMIUM = "/usr/bin/chromium"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """The app (no pipeline, no 3D view) under uvicorn in a thread, on a SQLite file in tmp."""
    import uvicorn

    from app.core.config import load_settings
    from app.main import create_app

    base = load_settings()
    port = free_port()
    settings = base.model_copy(
        update={
            "paths": base.paths.model_copy(update={"db": tmp_path_factory.mktemp("ui") / "cavewalk.db"}),
            "server": base.server.model_copy(update={"viser": False, "port": port}),
        }
    )
    app = create_app(settings, pipeline_factory=None)
    srv = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning"))
    thread = threading.Thread(target=srv.run, daemon=True)
    thread.start()
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 30
    while not srv.started:
        if time.monotonic() > deadline or not thread.is_alive():
            raise RuntimeError("the app did not start")
        time.sleep(0.05)
    try:
        yield url
    finally:
        srv.should_exit = True
        thread.join(timeout=10)


def test_questionnaire_form_and_analysis_panel(server: str, artifacts_dir: Path) -> None:
    from playwright.sync_api import expect, sync_playwright

    if not Path(CHROMIUM).exists():
        pytest.fail(f"{CHROMIUM} missing: apt-get install -y chromium")
    p = httpx.post(f"{server}/api/v1/participants", json={"code": "UI01"}).json()
    sid = httpx.post(f"{server}/api/v1/sessions", json={"participant_id": p["id"], "condition": "CC"}).json()[
        "id"
    ]
    with sync_playwright() as pw:
        browser = pw.chromium.launch(
            executable_path=CHROMIUM, args=["--headless", "--no-sandbox", "--disable-gpu"]
        )
        page = browser.new_page(viewport={"width": 1280, "height": 2000})
        errors: list[str] = []
        page.on("pageerror", lambda exc: errors.append(str(exc)))
        try:
            page.goto(server)
            row = page.locator("#session-table tbody tr").filter(has_text="UI01")
            row.locator("button.session-select").click()
            form = page.locator("#questionnaire-mount")
            form.locator("#q-instrument").select_option("ipq")
            expect(form.locator("#q-phase option")).to_have_count(2)
            # every IPQ item at 4 except REAL4, left out: the server's 422 names it, the row is marked
            for key in [
                "G1",
                "SP1",
                "SP2",
                "SP3",
                "SP4",
                "SP5",
                "INV1",
                "INV2",
                "INV3",
                "INV4",
                "REAL1",
                "REAL2",
                "REAL3",
            ]:
                form.locator(f'input[name="{key}"][value="4"]').check()
            form.locator("#q-submit").click()
            expect(form.locator("#q-error")).to_contain_text("REAL4")
            expect(form.locator('.q-row.q-bad[data-key="REAL4"]')).to_be_visible()
            form.locator('input[name="REAL4"][value="1"]').check()
            form.locator("#q-submit").click()
            # SP: (4 + (6-4) + 4 + 4 + 4) / 5 = 3.6; REAL: ((6-4) + 4 + 4 + 1) / 4 = 2.75
            expect(form.locator("#q-scores")).to_contain_text("SP: 3.6")
            expect(form.locator("#q-scores")).to_contain_text("REAL: 2.75")
            expect(form.locator("#q-error")).to_be_empty()

            # NASA-TLX: sliders, and the 15 pairwise choices (all first options -> weights 5..0)
            form.locator("#q-instrument").select_option("nasa_tlx")
            for key, value in {
                "mental": 70,
                "physical": 20,
                "temporal": 40,
                "performance": 30,
                "effort": 60,
                "frustration": 10,
            }.items():
                form.locator(f'input[name="{key}"]').fill(str(value))
            pairs = form.locator(".q-pair")
            expect(pairs).to_have_count(15)
            for i in range(15):
                pairs.nth(i).locator("input").first.check()
            form.locator("#q-submit").click()
            # raw = 230 / 6 = 38.33; weighted = (5x70 + 4x20 + 3x40 + 2x30 + 1x60) / 15 = 44.67
            expect(form.locator("#q-scores")).to_contain_text("raw_tlx: 38.33")
            expect(form.locator("#q-scores")).to_contain_text("weighted_tlx: 44.67")
            expect(form.locator("#q-done")).to_contain_text("NASA-TLX")
            page.screenshot(path=str(artifacts_dir / "questionnaire.png"), full_page=True)

            # the analysis panel: three figures that load, one table row per measure
            page.locator("#analysis-refresh").click()
            expect(page.locator("#analysis-table tbody tr")).to_have_count(17)
            imgs = page.locator("#analysis-figures img")
            expect(imgs).to_have_count(3)
            loaded = "[...document.querySelectorAll('#analysis-figures img')]"
            page.wait_for_function(f"{loaded}.every(i => i.complete && i.naturalWidth > 0)")
            expect(page.locator("#analysis-summary")).to_contain_text("UI01")
        finally:
            browser.close()
    assert not errors, f"JavaScript errors on the page: {errors}"
    stored = httpx.get(f"{server}/api/v1/sessions/{sid}/questionnaires").json()
    assert [q["instrument"] for q in stored] == ["ipq", "nasa_tlx"], "the rejected sheet was not stored"
