"""The camera-coverage panel in headless Chromium, against the real app on a real socket."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from pipeline.calibration.io import save_calibration
from pipeline.cave import box_cave
from pipeline.sim.scene import default_cameras
from tests.app.conftest import Served, make_settings
from tests.browser import CHROMIUM, chromium, watched_page

pytestmark = [pytest.mark.e2e, pytest.mark.slow]


def test_the_planner_panel_maps_the_default_layout_and_searches_mounts(
    tmp_path: Path, artifacts_dir: Path
) -> None:
    from playwright.sync_api import expect, sync_playwright

    if not Path(CHROMIUM).exists():
        pytest.fail(f"{CHROMIUM} missing: apt-get install -y chromium chromium-driver")
    s = make_settings(tmp_path)
    search = replace(s.planner.search, heights_m=(2.0, 2.45), pans_deg=(0.0,), aim_heights_m=(1.0,), top_k=2)
    planner = replace(s.planner, search=search, samples=1)
    settings = s.model_copy(update={"planner": planner})
    with (
        Served(settings, autostart=None, pipeline_factory=None) as served,
        sync_playwright() as pw,
        chromium(pw) as browser,
    ):
        errors: list[str] = []
        page = watched_page(browser, errors, viewport={"width": 1400, "height": 1800})
        page.goto(served.base)
        panel = page.locator("#planner-panel")
        expect(panel.locator("#planner-start")).to_be_visible(timeout=20_000)

        # no calibration is active yet: the server's refusal is shown
        panel.locator("#planner-start").click()
        expect(panel.locator("#planner-message")).to_contain_text(
            "no calibration is active yet", timeout=10_000
        )

        # a proposed set (calibration JSON) with a camera outside the room: refused, no job
        far = tmp_path / "far.json"
        save_calibration(far, default_cameras(box_cave(6.0, 6.0, 2.5)))
        panel.locator("#planner-source").select_option("proposed")
        panel.locator("#planner-file").set_input_files(str(far))
        panel.locator("#planner-start").click()
        expect(panel.locator("#planner-message")).to_contain_text("outside the room", timeout=10_000)

        # the simulator's default layout
        panel.locator("#planner-source").select_option("default")
        panel.locator("#planner-start").click()
        expect(panel.locator("#planner-message")).to_contain_text("plan 1: done", timeout=120_000)
        rows = panel.locator("#planner-regions tbody tr")
        expect(rows).to_have_count(4)
        corners = float(
            panel.locator('#planner-regions tr[data-region="corners"] td').nth(2).inner_text()
        )
        centre = float(panel.locator('#planner-regions tr[data-region="centre"] td').nth(2).inner_text())
        assert corners > centre, f"corners {corners} mm should be worse than the centre {centre} mm"
        img = panel.locator("#planner-figures img").first
        expect(img).to_be_visible()
        page.wait_for_function(
            "() => { const i = document.querySelector('#planner-figures img');"
            " return i && i.complete && i.naturalWidth > 500; }"
        )
        drawn = page.evaluate(
            "() => { const c = document.getElementById('planner-canvas');"
            " const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;"
            " let n = 0; for (let k = 3; k < d.length; k += 4) if (d[k]) n++; return n; }"
        )
        assert drawn > 10_000, "the per-joint map is drawn on the canvas"
        panel.locator("#planner-joint").select_option("nose")
        panel.locator("#planner-quantity").select_option("error")

        # a mount search for 4 cameras
        panel.locator("#planner-source").select_option("search")
        panel.locator("#planner-count").fill("4")
        panel.locator("#planner-start").click()
        expect(panel.locator("#planner-message")).to_contain_text("plan 2: done", timeout=180_000)
        layouts = panel.locator("#planner-layouts tbody tr")
        expect(layouts).to_have_count(3)  # best 1, best 2, default
        best_corner = float(layouts.nth(0).locator("td").nth(4).inner_text())
        default_corner = float(
            panel.locator('#planner-layouts tr[data-layout="default"] td').nth(4).inner_text()
        )
        assert best_corner < default_corner, (best_corner, default_corner)
        expect(panel.locator("#planner-figures img")).to_have_count(2)
        page.wait_for_function(
            "() => [...document.querySelectorAll('#planner-figures img')]"
            ".every(i => i.complete && i.naturalWidth > 500)"
        )
        page.evaluate("() => { document.querySelector('.topbar').style.position = 'static'; }")
        panel.screenshot(path=str(artifacts_dir / "planner_panel.png"))  # sticky top bar out of the way
    assert not errors, f"JavaScript errors on the page: {errors}"
