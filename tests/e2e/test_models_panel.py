"""The action models panel in headless Chromium against the real app: register a model file from the
dashboard, refuse a bad one, read a card, activate, roll back (issue 18 item 5); screenshots saved."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.app.conftest import Served, make_settings
from tests.app.models.onnx_files import three_class_model, with_metadata
from tests.app.models.takes_data import index_takes, one_heldout_source, simulated_takes, teach_take
from tests.browser import CHROMIUM, chromium, watched_page

pytestmark = [pytest.mark.e2e, pytest.mark.slow]


def test_models_panel_registers_activates_and_rolls_back(tmp_path: Path, artifacts_dir: Path) -> None:
    from playwright.sync_api import expect, sync_playwright

    if not Path(CHROMIUM).exists():
        pytest.fail(f"{CHROMIUM} missing: apt-get install -y chromium chromium-driver")
    good = with_metadata(tmp_path / "lab-model.onnx", note="from the dashboard")
    bad = three_class_model(tmp_path / "three-classes.onnx")
    with Served(make_settings(tmp_path), autostart=None, pipeline_factory=None) as served, \
            sync_playwright() as pw:
        with chromium(pw) as browser:
            errors: list[str] = []
            page = watched_page(browser, errors, viewport={"width": 1400, "height": 1000})
            page.goto(served.base)
            panel = page.locator("#models-panel")
            rows = panel.locator("#model-table tbody tr")
            expect(rows).to_have_count(1, timeout=20_000)
            expect(panel.locator("#model-active")).to_contain_text("active: model 1")

            panel.locator("#model-file").set_input_files(str(bad))
            panel.locator("#model-upload").click()
            expect(page.locator("#toast")).to_contain_text("one output", timeout=10_000)
            expect(rows).to_have_count(1)

            panel.locator("#model-file").set_input_files(str(good))
            panel.locator("#model-upload").click()
            expect(rows).to_have_count(2, timeout=10_000)
            new = panel.locator("#model-table tr[data-model-id='2']")
            expect(new).to_have_attribute("data-active", "false")
            new.locator("button.model-card-button").click()
            expect(panel.locator("#model-card")).to_be_visible()
            new.locator("button.model-activate").click()
            expect(new).to_have_attribute("data-active", "true", timeout=10_000)
            expect(panel.locator("#model-active")).to_contain_text("active: model 2")
            panel.screenshot(path=str(artifacts_dir / "models-activated.png"))

            panel.locator("#model-rollback").click()
            expect(panel.locator("#model-table tr[data-model-id='1']")).to_have_attribute(
                "data-active", "true", timeout=10_000
            )
            expect(new).to_have_attribute("data-active", "false")
            panel.screenshot(path=str(artifacts_dir / "models-rolled-back.png"))
        assert not errors, f"page errors: {errors}"


def test_the_fine_tune_button_runs_a_job_with_progress_and_registers_the_model(
    tmp_path: Path, artifacts_dir: Path
) -> None:
    from playwright.sync_api import expect, sync_playwright

    settings = make_settings(tmp_path)
    # the worker's own cache with one short held-out clip for the card (the user's cache may hold every
    # held-out source, each evaluated with both models: minutes)
    cache = tmp_path / "cache"
    one_heldout_source(cache)
    settings = settings.model_copy(update={"paths": settings.paths.model_copy(update={"cache_dir": cache})})
    with Served(settings, autostart=None, pipeline_factory=None) as served, sync_playwright() as pw:
        with served.app.state.session_factory() as db:
            index_takes(db, simulated_takes(tmp_path / "takes", duration_s=10.0))
        with chromium(pw) as browser:
            errors: list[str] = []
            page = watched_page(browser, errors, viewport={"width": 1400, "height": 1200})
            page.goto(served.base)
            panel = page.locator("#models-panel")
            boxes = panel.locator("#train-takes input[type=checkbox]")
            expect(boxes).to_have_count(2, timeout=20_000)
            boxes.nth(0).check()
            boxes.nth(1).check()
            panel.locator("#train-epochs").fill("1")
            panel.locator("#train-sim").fill("1")
            panel.locator("#train-windows").fill("256")
            panel.locator("#train-start").click()
            state = panel.locator("#train-state")
            expect(state).to_contain_text("job 1", timeout=10_000)
            # a worker process that imports torch and fine-tunes three times on a shared 2-core machine
            expect(state).to_have_attribute("data-state", "done", timeout=300_000)
            expect(state).to_contain_text("registered as model 2")
            expect(panel.locator("#train-log")).to_contain_text("fold P2")
            row = panel.locator("#model-table tr[data-model-id='2']")
            expect(row).to_contain_text("trained", timeout=10_000)
            panel.screenshot(path=str(artifacts_dir / "models-fine-tuned.png"))
            row.locator("button.model-card-button").click()
            expect(panel.locator("#model-card")).to_contain_text("Leave-one-participant-out")
            expect(panel.locator("#model-card")).to_contain_text("blind-heldout")
        assert not errors, f"page errors: {errors}"


def test_the_teach_button_adapts_to_a_participant_and_can_be_switched_off(
    tmp_path: Path, artifacts_dir: Path
) -> None:
    from playwright.sync_api import expect, sync_playwright

    with Served(make_settings(tmp_path), autostart=None, pipeline_factory=None) as served, \
            sync_playwright() as pw:
        with served.app.state.session_factory() as db:
            index_takes(db, [teach_take(tmp_path, "T7")])
        with chromium(pw) as browser:
            errors: list[str] = []
            page = watched_page(browser, errors, viewport={"width": 1400, "height": 1200})
            page.goto(served.base)
            panel = page.locator("#models-panel")
            expect(panel.locator("#teach-take option")).to_have_count(1, timeout=20_000)
            panel.locator("#teach-start").click()
            result = panel.locator("#teach-result")
            expect(result).to_contain_text("participant T7: held-back accuracy", timeout=60_000)
            row = panel.locator("#adaptation-table tr[data-adaptation-id='1']")
            expect(row).to_contain_text("T7")
            was_on = row.get_attribute("data-enabled") == "true"
            panel.screenshot(path=str(artifacts_dir / "models-teach.png"))
            row.locator("button.adaptation-toggle").click()
            expect(row).to_have_attribute("data-enabled", "false" if was_on else "true", timeout=10_000)
        assert not errors, f"page errors: {errors}"


def test_a_model_activated_while_the_pipeline_runs_is_used_after_restart_now(
    tmp_path: Path, artifacts_dir: Path
) -> None:
    """The simulator runs; a model activated in the panel is not used by the running pipeline: the
    top bar says so until "Restart now" starts the pipeline again, with that model."""
    import base64

    import httpx
    from playwright.sync_api import expect, sync_playwright

    from tests.waiting import HTTP_TIMEOUT_S

    if not Path(CHROMIUM).exists():
        pytest.fail(f"{CHROMIUM} missing: apt-get install -y chromium chromium-driver")
    good = with_metadata(tmp_path / "lab-model.onnx", note="for the restart")
    with Served(make_settings(tmp_path)) as served, sync_playwright() as pw:
        r = httpx.post(f"{served.base}/api/v1/models", timeout=HTTP_TIMEOUT_S,
                       json={"name": good.name, "onnx_base64": base64.b64encode(good.read_bytes()).decode()})
        assert r.status_code == 201, r.text
        served.wait_status(lambda s: s["state"] == "running")
        with chromium(pw) as browser:
            errors: list[str] = []
            page = watched_page(browser, errors, viewport={"width": 1400, "height": 1000})
            page.goto(served.base)
            notice = page.locator("#restart-notice")
            expect(page.locator("#state")).to_have_text("running", timeout=30_000)
            expect(notice).to_be_hidden()
            page.locator("#models-panel #model-table tr[data-model-id='2'] button.model-activate").click()
            expect(page.locator("#toast")).to_contain_text("from its next start", timeout=10_000)
            expect(notice).to_be_visible(timeout=10_000)
            expect(notice).to_contain_text("does not use the activated action model until it starts again")
            assert served.app.state.models.running["id"] == 1, "the running pipeline keeps its model"
            page.locator("header.topbar").screenshot(path=str(artifacts_dir / "restart-notice.png"))
            notice.locator("#pipeline-restart").click()
            expect(notice).to_be_hidden(timeout=60_000)
            expect(page.locator("#state")).to_have_text("running", timeout=60_000)
            assert served.app.state.models.running["id"] == 2, "started again with the activated model"
            status = httpx.get(f"{served.base}/api/v1/status", timeout=HTTP_TIMEOUT_S).json()
            assert status["restart_for"] == [] and status["source"] == "simulator", status
        assert not errors, f"page errors: {errors}"
