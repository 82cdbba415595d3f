"""The takes panel in headless Chromium against the real app (simulator pipeline): record a take with
a protocol, see its prompt and progress, and find it complete in the list."""

from __future__ import annotations

import json
import re
from pathlib import Path

import httpx
import pytest

from tests.app.conftest import Served, make_settings
from tests.browser import CHROMIUM, chromium, watched_page
from tests.waiting import wait_until

pytestmark = [pytest.mark.e2e, pytest.mark.slow]


def test_record_a_take_from_the_dashboard(tmp_path: Path, artifacts_dir: Path) -> None:
    from playwright.sync_api import expect, sync_playwright

    if not Path(CHROMIUM).exists():
        pytest.fail(f"{CHROMIUM} missing: apt-get install -y chromium chromium-driver")
    with Served(make_settings(tmp_path, viser=True)) as served, sync_playwright() as pw:
        served.wait_status(lambda st: st["state"] == "running" and st["navigator"] is not None, 60)
        with chromium(pw) as browser:
            errors: list[str] = []
            page = watched_page(browser, errors, viewport={"width": 1400, "height": 1000})
            # the embedded 3D view's own page (WebGL in software, heavy on 2 cores) is not under test
            # here: the replay's scene is read from the app's viser server below
            page.route("**/viewer/**", lambda route: route.abort())
            page.goto(served.base)
            panel = page.locator("#recording-panel")
            expect(panel.locator("#take-protocol option[value='four-actions']")).to_be_attached(
                timeout=20_000
            )
            panel.locator("#take-participant").fill("PW1")
            panel.locator("#take-protocol").select_option("four-actions")
            panel.locator("#take-duration").fill("7")
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
            # the timeline label editor: drag the boundary after the margin, relabel the forward span
            row.locator("button.take-labels").click()
            track = panel.locator("#label-track")
            expect(track.locator(".label-span")).to_have_count(3, timeout=10_000)
            expect(track.locator(".label-handle")).to_have_count(2)
            track.scroll_into_view_if_needed()
            box = track.bounding_box()
            assert box is not None
            spans = httpx.get(f"{served.base}/api/v1/takes/1/labels").json()["spans"]
            duration = max(spans[-1]["t_end"], 0.1)
            handle = track.locator(".label-handle").nth(1).bounding_box()
            assert handle is not None
            page.mouse.move(handle["x"] + handle["width"] / 2, handle["y"] + handle["height"] / 2)
            page.mouse.down()
            target_t = 6.0
            page.mouse.move(
                box["x"] + box["width"] * target_t / duration, box["y"] + box["height"] / 2, steps=8
            )
            page.mouse.up()
            expect(panel.locator("#label-info")).to_have_text("unsaved changes")
            # the 3D view replays the take at the boundary being dragged, in place of the live people
            replay = panel.locator("#label-replay")
            expect(replay).to_contain_text("3D view:", timeout=10_000)
            viewer = served.app.state.viewer
            assert viewer.replay_until > 0 and viewer.people, "the take's people are in the 3D view"
            title = track.locator(".label-span").nth(1).get_attribute("title") or ""
            boundary = float(re.search(r"–([0-9.]+) s", title).group(1))  # type: ignore[union-attr]
            uid = httpx.get(f"{served.base}/api/v1/takes/1").json()["uid"]
            frames = (served.settings.paths.db.parent / "takes" / uid / "frames.jsonl").read_text()
            times = [json.loads(line)["t"] for line in frames.splitlines()]

            def shows_the_boundary() -> bool:  # the last frame captured at or before it
                t = float(replay.get_attribute("data-t") or "nan")
                later = any(t < x < boundary - 0.005 for x in times)
                return t in times and t <= boundary + 0.005 and not later

            wait_until(shows_the_boundary, "the 3D view at the dragged boundary", 20)
            panel.locator("#label-scrub").fill("1.5")
            expect(replay).to_have_attribute("data-t", re.compile(r"^1\.[0-5]"), timeout=10_000)
            panel.screenshot(path=str(artifacts_dir / "takes-replay.png"))
            panel.locator("#label-live").click()
            expect(replay).to_have_text("3D view: live", timeout=10_000)
            assert viewer.replay_until == 0.0
            track.locator(".label-span").nth(2).click()
            panel.locator("#label-choice").select_option("right")
            panel.locator("#label-apply").click()
            expect(track.locator(".label-span").nth(2)).to_have_attribute("data-label", "right")
            panel.locator("#label-save").click()
            expect(panel.locator("#label-info")).to_have_text("saved", timeout=10_000)
            panel.screenshot(path=str(artifacts_dir / "takes-label-editor.png"))
            # the exports: the labels table has the operator's relabelling, the TRC Pose2Sim's header
            with page.expect_download() as got:
                row.locator("a.take-export[data-format='labels']").click()
            table = Path(got.value.path()).read_text().splitlines()
            assert table[0].startswith("take,participant_code,user_id,frame,t_s,label"), table[:2]
            assert any(",right," in line for line in table[1:]), "the edited labels are exported"
            with page.expect_download() as got:
                row.locator("a.take-export[data-format='trc']").click()
            assert got.value.suggested_filename.endswith(".trc")
            assert Path(got.value.path()).read_text().startswith("PathFileType\t4\t(X/Y/Z)")
            row.screenshot(path=str(artifacts_dir / "takes-export-links.png"))
            # videos of the simulator: it has no camera images; one clear message, nothing stored
            panel.locator("#take-videos").check()
            panel.locator("#take-start").click()
            expect(page.locator("#toast")).to_contain_text("has no camera images", timeout=10_000)
            panel.locator("#take-videos").uncheck()
            # a bad margin: one clear message, no take stored
            panel.locator("#take-margin").fill("9")
            panel.locator("#take-start").click()
            expect(page.locator("#toast")).to_contain_text("margin_s must be", timeout=10_000)
        saved = httpx.get(f"{served.base}/api/v1/takes/1/labels").json()["spans"]
        assert [x["label"] for x in saved] == ["still", "ignore", "right"], saved
        assert abs(saved[1]["t_end"] - target_t) < 0.3 and saved[2]["t_start"] == saved[1]["t_end"], saved
        assert saved[2]["source"] == "operator"
        takes = httpx.get(f"{served.base}/api/v1/takes").json()
        assert [(t["participant_code"], t["status"], t["margin_s"]) for t in takes] == [
            ("PW1", "complete", 0.3)
        ]
        assert not errors, errors
