"""A protocol take prompts the participant: the prompt page in headless Chromium shows each step in
large type with a countdown, and the workstations get `prompt` datagrams that `cavewalk receive`
checks on a real UDP socket."""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time
from pathlib import Path

import httpx
import pytest

from tests.app.conftest import Served, make_settings
from tests.browser import CHROMIUM, chromium, watched_page
from tests.waiting import free_udp_port

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]
PROTOCOL = 'name = "prompt test"\nsteps = ["still 3 s", "forward 4 s", "crouch 3 s (label still)"]\n'


def test_the_prompt_page_and_the_prompt_datagrams_follow_the_protocol(
    tmp_path: Path, artifacts_dir: Path
) -> None:
    from playwright.sync_api import expect, sync_playwright

    if not Path(CHROMIUM).exists():
        pytest.fail(f"{CHROMIUM} missing: apt-get install -y chromium chromium-driver")
    udp = free_udp_port()
    settings = make_settings(tmp_path).model_copy(update={"workstations": [f"127.0.0.1:{udp}"]})
    with Served(settings) as served, sync_playwright() as pw:
        served.wait_status(lambda st: st["state"] == "running" and st["navigator"] is not None, 120)
        receiver = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "app.cli",
                "receive",
                "--port",
                str(udp),
                "--host",
                "127.0.0.1",
                "--duration",
                "60",
                "--json",
            ],
            cwd=ROOT,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        assert receiver.stdout is not None
        lines: list[str] = []
        reader = threading.Thread(target=lambda: lines.extend(receiver.stdout), daemon=True)  # type: ignore[arg-type]
        reader.start()
        with chromium(pw) as browser:
            errors: list[str] = []
            page = watched_page(browser, errors, viewport={"width": 1280, "height": 800})
            deadline = time.monotonic() + 120
            while not lines and time.monotonic() < deadline:  # the receiver is up: it has a heartbeat
                time.sleep(0.2)
            assert lines, "cavewalk receive got no heartbeat"
            page.goto(f"{served.base}/prompt.html")
            expect(page.locator("#prompt-text")).to_contain_text(
                "Waiting for the experimenter", timeout=15_000
            )
            r = httpx.post(
                f"{served.base}/api/v1/takes", json={"protocol_toml": PROTOCOL, "participant_code": "PR1"}
            )
            assert r.status_code == 201, r.text
            take_id = r.json()["id"]
            expect(page.locator("#prompt-text")).to_have_text("Stand still", timeout=10_000)
            expect(page.locator("#prompt")).to_have_attribute("data-label", "still")
            expect(page.locator("#prompt-next")).to_have_text("next: Step forward on the spot")
            expect(page.locator("#prompt-text")).to_have_text("Step forward on the spot", timeout=10_000)
            expect(page.locator("#prompt-step")).to_have_text("step 2 of 3")
            countdown = int(page.locator("#prompt-countdown").inner_text())
            assert 1 <= countdown <= 4, countdown
            font_px = page.evaluate(
                "() => parseFloat(getComputedStyle(document.getElementById('prompt-text')).fontSize)"
            )
            assert font_px >= 60, f"large type for a wall: {font_px}px"
            page.screenshot(path=str(artifacts_dir / "prompt-page.png"))
            expect(page.locator("#prompt-text")).to_have_text("Crouch", timeout=10_000)
            expect(page.locator("#prompt-text")).to_contain_text("Waiting", timeout=20_000)
        row = httpx.get(f"{served.base}/api/v1/takes/{take_id}").json()
        receiver.terminate()
        receiver.wait(timeout=30)
        reader.join(timeout=10)
    assert row["status"] == "complete", row
    got = [json.loads(x) for x in lines if x.startswith("{")]
    summary = got[-1]["summary"]
    assert all(x["valid"] for x in got[:-1]), [x for x in got[:-1] if not x["valid"]][:3]
    prompts = [x["message"] for x in got[:-1] if x["message"]["type"] == "prompt"]
    assert summary["invalid"] == 0 and summary["by_type"].get("prompt", 0) == len(prompts) > 0, summary
    assert next(p["text"] for p in prompts) == "Stand still"
    seen = list(dict.fromkeys((p["text"], p["label"]) for p in prompts))
    assert seen == [("Stand still", "still"), ("Step forward on the spot", "forward"), ("Crouch", "still")], (
        seen
    )
    assert all(0 <= p["remaining_s"] <= 4 for p in prompts)
    assert not errors, errors
