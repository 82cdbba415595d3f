"""The whole system: `cavewalk demo` as a real subprocess, the dashboard in headless Chromium."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]
CHROMIUM = "/usr/bin/chromium"
SSQ_KEYS = [
    "general_discomfort", "fatigue", "headache", "eye_strain", "difficulty_focusing", "increased_salivation",
    "sweating", "nausea", "difficulty_concentrating", "fullness_of_head", "blurred_vision", "dizzy_eyes_open",
    "dizzy_eyes_closed", "vertigo", "stomach_awareness", "burping",
]  # fmt: skip


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture(scope="module")
def demo_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """`cavewalk demo` on free ports with a database in tmp; yields its base URL."""
    tmp = tmp_path_factory.mktemp("demo")
    port, viser_port = free_port(), free_port()
    log = (tmp / "server.log").open("w")
    cmd = [sys.executable, "-m", "app.cli", "demo", "--port", str(port), "--viser-port", str(viser_port),
           "--db", str(tmp / "demo.db")]  # fmt: skip
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=log, stderr=subprocess.STDOUT, start_new_session=True,
                            env={**os.environ, "PYTHONUNBUFFERED": "1"})  # fmt: skip
    base = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 60
        while True:
            if proc.poll() is not None:
                raise RuntimeError(f"cavewalk demo exited: {(tmp / 'server.log').read_text()}")
            try:
                if httpx.get(f"{base}/api/v1/health", timeout=1).status_code == 200:
                    break
            except httpx.HTTPError:
                pass
            if time.monotonic() > deadline:
                raise RuntimeError("cavewalk demo did not answer within 60 s")
            time.sleep(0.2)
        yield base
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            code = proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            raise AssertionError("cavewalk demo did not stop within 30 s of Ctrl-C") from None
        finally:
            log.close()
        assert code == 0, f"cavewalk demo exited with {code}: {(tmp / 'server.log').read_text()[-2000:]}"
        deadline = time.monotonic() + 10  # multiprocessing's helpers exit once they see the parent gone
        while True:
            left = subprocess.run(["pgrep", "-a", "-g", str(proc.pid)], capture_output=True, text=True)
            left = left.stdout.strip().splitlines()
            if not left or time.monotonic() > deadline:
                break
            time.sleep(0.2)
        if left:
            os.killpg(proc.pid, signal.SIGKILL)
        assert not left, f"worker processes left after Ctrl-C: {left}"


def test_demo_dashboard_live_navigator_and_ssq(demo_server: str, artifacts_dir: Path) -> None:
    from playwright.sync_api import expect, sync_playwright

    if not Path(CHROMIUM).exists():
        pytest.fail(f"{CHROMIUM} missing: apt-get install -y chromium chromium-driver")
    # the demo's live pipeline shares two cores with the browser (and, in CI, with other jobs): an
    # API round trip and the re-render after it can take seconds; the outcomes are awaited, not raced
    expect.set_options(timeout=20_000)
    with sync_playwright() as pw:
        browser = pw.chromium.launch(
            executable_path=CHROMIUM,
            args=["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking"],
        )
        page = browser.new_page(viewport={"width": 1400, "height": 2400})
        errors: list[str] = []
        page.on("pageerror", lambda exc: errors.append(str(exc)))
        try:
            page.goto(demo_server)
            # live status arrives over the WebSocket and changes
            expect(page.locator("#state")).to_have_text("running", timeout=60_000)
            expect(page.locator("#ws-state")).to_have_text("live: open")
            first_fps = page.locator("#fps").inner_text()
            expect(page.locator("#fps")).not_to_have_text(first_fps, timeout=10_000)
            expect(page.locator("#latency-table tbody tr").first).to_be_visible()

            # select a navigator by a click on a tracked person
            people = page.locator("button.person")
            expect(people.nth(1)).to_be_visible(timeout=30_000)
            current = page.locator("#navigator").inner_text()
            # read the ids in one go (the list re-renders live); the lowest other id is the longest-lived
            candidates = people.evaluate_all("els => els.map(e => e.dataset.userId)")
            target = min((uid for uid in candidates if uid != current), key=int)
            page.locator(f'button.person[data-user-id="{target}"]').click()
            expect(page.locator("#navigator")).to_have_text(target, timeout=10_000)
            expect(page.locator("#navigator-mode")).to_have_text("manual")
            expect(page.locator(f'button.person.navigator[data-user-id="{target}"]')).to_be_visible()

            # study panel: a participant, a session, select it
            page.fill("#participant-code", "E2E01")
            page.click("#participant-add")
            expect(page.locator("#participant-table tbody")).to_contain_text("E2E01")
            page.select_option("#session-condition", "EC")
            page.click("#session-add")
            row = page.locator("#session-table tbody tr").filter(has_text="E2E01")
            expect(row).to_have_count(1)
            row.locator("button.session-start").click()
            expect(row.locator(".status")).to_have_text("running")
            expect(page.locator("#running-session")).not_to_have_text("none")
            row.locator("button.session-select").click()

            # the questionnaire form (the study module's), filled like on a tablet
            panel = page.locator("#questionnaire-panel")
            panel.locator("#q-instrument").select_option("ssq")
            panel.locator("#q-phase").select_option("post")
            answers = {k: 0 for k in SSQ_KEYS} | {"nausea": 2, "headache": 1, "vertigo": 3, "fatigue": 1}
            for key, value in answers.items():
                panel.locator(f'input[name="{key}"][value="{value}"]').check()  # waits for a still layout
            panel.locator("#q-submit").click()
            # Kennedy et al. 1993: N = {nausea 2} -> 2; O = {fatigue 1, headache 1} -> 2; D = {nausea 2,
            # vertigo 3} -> 5; total = (2 + 2 + 5) x 3.74 = 33.66
            expect(panel.locator("#q-scores")).to_contain_text("total: 33.66", timeout=10_000)
            page.screenshot(path=str(artifacts_dir / "dashboard.png"), full_page=True)
        finally:
            browser.close()
    assert not errors, f"JavaScript errors on the page: {errors}"
    stored = httpx.get(f"{demo_server}/api/v1/sessions").json()
    sid = next(s["id"] for s in stored if s["participant_code"] == "E2E01")
    q = httpx.get(f"{demo_server}/api/v1/sessions/{sid}/questionnaires").json()
    assert len(q) == 1 and q[0]["answers"] == answers and q[0]["scores"]["total"] == pytest.approx(33.66)
