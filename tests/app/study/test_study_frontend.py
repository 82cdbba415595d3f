"""A scripted study session in headless Chromium against the real app and a real SQLite file:
planned from a Latin square on the operator's dashboard (1600x1000), run from the participant page on
a tablet-sized page (its link, its session-scoped credential), auto-stopped by the server, every
questionnaire on the tablet, a duplicate refused then corrected with a reason on the operator's
form, and the analysis panel. Screenshots go to test-artifacts/.
"""

from __future__ import annotations

import sqlite3
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

from app.study.questionnaires import DEFINITIONS, SSQ_KEYS, TLX_PAIRS
from tests.browser import CHROMIUM, chromium, watched_page
from tests.waiting import free_port

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

TABLET = {"width": 820, "height": 1180}  # a 10.9" tablet, portrait
OPERATOR = {"width": 1600, "height": 1000}
TLX = {"mental": 70, "physical": 20, "temporal": 40, "performance": 30, "effort": 60, "frustration": 10}


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


def fill_radios(page: Any, values: dict[str, Any]) -> None:
    for key, value in values.items():
        page.locator(f'input[name="{key}"][value="{value}"]').check()


def test_scripted_session_on_the_participant_page(server: str, artifacts_dir: Path) -> None:
    from playwright.sync_api import expect, sync_playwright

    if not Path(CHROMIUM).exists():
        pytest.fail(f"{CHROMIUM} missing: apt-get install -y chromium")
    api = f"{server}/api/v1"
    with sync_playwright() as pw, chromium(pw) as browser:
        errors: list[str] = []
        operator = watched_page(browser, errors, "operator", viewport=OPERATOR)
        tablet = watched_page(browser, errors, "tablet", viewport=TABLET, is_mobile=True, has_touch=True)
        # --- plan: 2 participants, both sessions each, from the Latin square; a 6 s run
        operator.goto(server)
        operator.fill("#plan-n", "2")
        operator.fill("#plan-minutes", "0.1")
        operator.click("#plan-create")
        rows = operator.locator("#session-table tbody tr")
        expect(rows).to_have_count(4)
        expect(rows.first.locator(".run-time")).to_have_text("6 s planned")
        expect(operator.locator("#participant-table tbody")).to_contain_text("CC first")
        expect(operator.locator("#participant-table tbody")).to_contain_text("EC first")
        first = rows.filter(has_text="P01").first
        sid = int(first.locator("td").first.inner_text())
        first.locator("button.session-select").click()
        expect(operator.locator("#q-session")).to_contain_text(f"session {sid}")
        operator.click("#participant-link")
        url = operator.locator("#participant-url").get_attribute("href")
        assert url is not None and "#t=" in url and "token" not in url, url

        # --- the tablet: one instrument at a time, progress, no operator controls
        tablet.goto(url)
        expect(tablet.locator("#p-title")).to_contain_text("MSSQ")
        expect(tablet.locator("#p-progress-text")).to_have_text("Questionnaire 1 of 5")
        assert tablet.locator("#pipeline-start, #q-instrument, .topbar").count() == 0
        assert "#t=" not in tablet.url, "the credential leaves the address bar"
        fill_radios(tablet, {i.key: 1 for i in DEFINITIONS["mssq"].items})
        tablet.click("#p-submit")
        expect(tablet.locator("#p-title")).to_contain_text("Simulator Sickness")
        # three symptoms left out: all three are named at once, in the instrument's wording
        fill_radios(tablet, {k: 0 for k in SSQ_KEYS if k not in ("sweating", "vertigo", "burping")})
        tablet.click("#p-submit")
        problems = tablet.locator("#p-problems")
        expect(problems).to_contain_text("Please answer these 3 questions")
        for text in ("Sweating", "Vertigo", "Burping"):
            expect(problems).to_contain_text(text)
        expect(tablet.locator(".q-row.q-bad")).to_have_count(3)
        tablet.screenshot(path=str(artifacts_dir / "participant-missing-items.png"), full_page=False)
        fill_radios(tablet, {"sweating": 1, "vertigo": 0, "burping": 0})
        tablet.click("#p-submit")
        expect(tablet.locator("#p-ready")).to_contain_text("experimenter will start")

        # --- the operator starts the run; the server stops it after 6 s
        operator.locator(f'#session-table tbody tr[data-session-id="{sid}"] button.session-start').click()
        expect(tablet.locator("#p-countdown")).to_be_visible(timeout=10_000)
        expect(operator.locator("#run-countdown")).to_be_visible()
        operator.screenshot(path=str(artifacts_dir / "operator-view.png"))
        # the auto-stop: the tablet goes on by itself (deadline: the 6 s run + polling, generous)
        expect(tablet.locator("#p-title")).to_contain_text("Simulator Sickness", timeout=30_000)
        expect(tablet.locator("#p-progress-text")).to_have_text("Questionnaire 3 of 5")
        # the sheet is empty: nothing carries over from the SSQ before the session
        expect(tablet.locator('input[type="radio"]:checked')).to_have_count(0)
        fill_radios(tablet, {k: 1 if k == "nausea" else 0 for k in SSQ_KEYS})
        tablet.click("#p-submit")
        expect(tablet.locator("#p-title")).to_contain_text("igroup presence")
        fill_radios(tablet, {i.key: 4 for i in DEFINITIONS["ipq"].items})
        tablet.click("#p-submit")

        # --- NASA-TLX: one slider left untouched is unanswered, and refused
        expect(tablet.locator("#p-title")).to_contain_text("NASA")
        for key, value in TLX.items():
            if key != "frustration":
                tablet.locator(f'input[type="range"][name="{key}"]').fill(str(value))
        pairs = tablet.locator(".q-pair")
        expect(pairs).to_have_count(15)
        order = [pairs.nth(i).get_attribute("data-key") for i in range(15)]
        assert order != [f"{a}_vs_{b}" for a, b in TLX_PAIRS], "the pairs come in a random order"
        fill_radios(tablet, {f"{a}_vs_{b}": a for a, b in TLX_PAIRS})
        tablet.click("#p-submit")
        expect(problems).to_contain_text("Frustration")
        expect(tablet.locator('.q-row.q-bad[data-key="frustration"]')).to_be_visible()
        tablet.locator('input[type="range"][name="frustration"]').fill("10")
        tablet.click("#p-submit")
        expect(tablet.locator("#p-end")).to_contain_text("hand the tablet back")
        # the server backed the database up when the timer ended the session; the panel says so
        expect(operator.locator("#backup-state")).to_contain_text("(session end)", timeout=20_000)
        expect(tablet.locator("#p-progress-text")).to_have_text("All done")
        assert "score" not in tablet.locator("body").inner_text().lower(), "no scores on the tablet"
        tablet.screenshot(path=str(artifacts_dir / "participant-end.png"))

        # --- the operator's form: a duplicate is refused, then sent as a correction with a reason
        form = operator.locator("#questionnaire-mount")
        form.locator("#q-instrument").select_option("ipq")
        expect(form.locator("#q-phase")).to_have_value("post")
        fill_radios(operator, {i.key: 5 for i in DEFINITIONS["ipq"].items})
        form.locator("#q-submit").click()
        expect(form.locator("#q-error")).to_contain_text("already has IPQ post")
        form.locator("#q-correct-reason").fill("participant asked to change item 3")
        form.locator("#q-correct").click()
        expect(form.locator("#q-scores")).to_contain_text("G1: 5")
        operator.locator("#analysis-refresh").click()
        expect(operator.locator("#analysis-table tbody tr")).to_have_count(17)
        expect(operator.locator("#analysis-caption")).to_contain_text("Holm")
        loaded = "[...document.querySelectorAll('#analysis-figures img')]"
        ready = f"{loaded}.length === 3 && {loaded}.every(i => i.complete && i.naturalWidth > 0)"
        operator.wait_for_function(ready)
        operator.locator("#session-panel").scroll_into_view_if_needed()
        expect(operator.locator("#summary-list")).to_contain_text("run time")
        operator.screenshot(path=str(artifacts_dir / "operator-full.png"), full_page=True)
    assert not errors, f"JavaScript errors on the pages: {errors}"
    session = httpx.get(f"{api}/sessions/{sid}").json()
    assert session["status"] == "stopped" and session["stopped_by"] == "timer"
    assert 5.5 <= session["duration_s"] <= 20, session
    entries = httpx.get(f"{api}/sessions/{sid}/questionnaires").json()
    used = [(q["instrument"], q["phase"], q["entered_by"]) for q in entries if q["in_use"]]
    assert used == [
        ("mssq", "pre", "participant"),
        ("ssq", "pre", "participant"),
        ("ssq", "post", "participant"),
        ("nasa_tlx", "post", "participant"),
        ("ipq", "post", "operator"),
    ], used
    backups = httpx.get(f"{api}/backups").json()
    (end,) = [b for b in backups["backups"] if b["reason"] == "session-end"]
    assert backups["last_error"] is None
    con = sqlite3.connect(Path(backups["folder"]) / end["name"])  # the copy holds the ended session
    try:
        row = con.execute("SELECT status FROM study_sessions WHERE id = ?", (sid,)).fetchone()
        assert row == ("stopped",)
    finally:
        con.close()
    replaced = next(q for q in entries if q["instrument"] == "ipq" and not q["in_use"])
    assert replaced["entered_by"] == "participant" and replaced["scores"]["G1"] == 4
    tlx = next(q for q in entries if q["instrument"] == "nasa_tlx")
    assert tlx["answers"] == TLX and tlx["scores"]["weighted_tlx"] == pytest.approx(670 / 15, abs=1e-3)


def test_a_lost_connection_and_a_reload_lose_no_answer_on_the_tablet(
    server: str, artifacts_dir: Path
) -> None:
    """The tablet goes offline (the browser's own network switch) half-way through a sheet: the answers
    stay, a notice says so, a Next while offline is kept for later; back online the page goes on by
    itself, a reload brings the answers back, and Next stores exactly them."""
    from playwright.sync_api import expect, sync_playwright

    api = f"{server}/api/v1"
    pid = httpx.post(f"{api}/participants", json={"code": "W01"}).json()["id"]
    sid = httpx.post(f"{api}/sessions", json={"participant_id": pid, "condition": "CC"}).json()["id"]
    url = httpx.post(f"{api}/sessions/{sid}/participant-link").json()["url"]
    items = [i.key for i in DEFINITIONS["mssq"].items]
    given = {key: i % 4 for i, key in enumerate(items)}
    with sync_playwright() as pw, chromium(pw) as browser:
        errors: list[str] = []
        tablet = watched_page(browser, errors, "tablet", viewport=TABLET, is_mobile=True, has_touch=True)
        tablet.goto(url)
        expect(tablet.locator("#p-title")).to_contain_text("MSSQ")
        checked = tablet.locator('input[type="radio"]:checked')
        fill_radios(tablet, {k: given[k] for k in items[:4]})
        tablet.context.set_offline(True)
        tablet.wait_for_timeout(4500)  # two polls (every 2 s) fail
        expect(checked).to_have_count(4)
        offline = tablet.locator("#p-offline")
        expect(offline).to_be_visible()
        fill_radios(tablet, {k: given[k] for k in items[4:]})
        tablet.click("#p-submit")
        expect(tablet.locator("#p-problems")).to_contain_text("could not be sent")
        expect(checked).to_have_count(len(items))
        tablet.screenshot(path=str(artifacts_dir / "participant-offline.png"))
        tablet.context.set_offline(False)
        expect(offline).to_be_hidden(timeout=10_000)
        expect(tablet.locator("#p-title")).to_contain_text("MSSQ")
        tablet.reload()
        expect(tablet.locator("#p-title")).to_contain_text("MSSQ")
        expect(checked).to_have_count(len(items))
        tablet.click("#p-submit")
        expect(tablet.locator("#p-title")).to_contain_text("Simulator Sickness")
        expect(checked).to_have_count(0)  # the next sheet starts empty: the draft was this step's
        tablet.reload()
        expect(tablet.locator("#p-title")).to_contain_text("Simulator Sickness")
        expect(checked).to_have_count(0)
    assert not errors, errors
    (stored,) = httpx.get(f"{api}/sessions/{sid}/questionnaires").json()
    assert stored["instrument"] == "mssq" and stored["answers"] == given, stored


def test_a_next_whose_reply_was_lost_goes_on_to_the_next_sheet_when_pressed_again(server: str) -> None:
    """The tablet's Next reaches the server (the answers are stored) but its reply is lost, and the
    page's polls fail for a moment: pressing Next again is refused by the server (that sheet is no
    longer due), and the page shows the sheet that is due instead of the refusal. Stored once."""
    from playwright.sync_api import expect, sync_playwright

    api = f"{server}/api/v1"
    pid = httpx.post(f"{api}/participants", json={"code": "W02"}).json()["id"]
    sid = httpx.post(f"{api}/sessions", json={"participant_id": pid, "condition": "CC"}).json()["id"]
    url = httpx.post(f"{api}/sessions/{sid}/participant-link").json()["url"]
    items = [i.key for i in DEFINITIONS["mssq"].items]
    given = {key: (i + 1) % 4 for i, key in enumerate(items)}
    with sync_playwright() as pw, chromium(pw) as browser:
        errors: list[str] = []
        tablet = watched_page(browser, errors, "tablet", viewport=TABLET, is_mobile=True, has_touch=True)
        tablet.goto(url)
        expect(tablet.locator("#p-title")).to_contain_text("MSSQ")
        tablet.evaluate("""() => {  // every text the problems box ever shows
            window.problemTexts = [];
            const box = document.getElementById("p-problems");
            new MutationObserver(() => window.problemTexts.push(box.textContent))
                .observe(box, {childList: true, subtree: true, characterData: true});
        }""")
        fill_radios(tablet, {k: given[k] for k in items})

        def stored_then_lost(route: Any) -> None:
            route.fetch()  # the server stores the answers ...
            route.abort("connectionreset")  # ... and the tablet never gets the reply

        def poll_lost(route: Any) -> None:
            route.abort("connectionreset")

        tablet.route("**/participant/questionnaires", stored_then_lost)
        tablet.route("**/participant/session", poll_lost)
        tablet.click("#p-submit")
        expect(tablet.locator("#p-problems")).to_contain_text("could not be sent")
        assert len(httpx.get(f"{api}/sessions/{sid}/questionnaires").json()) == 1, "stored"
        tablet.unroute("**/participant/questionnaires")
        tablet.unroute("**/participant/session")
        tablet.click("#p-submit")  # before the next poll: the server says this sheet is not due
        expect(tablet.locator("#p-title")).to_contain_text("Simulator Sickness", timeout=10_000)
        expect(tablet.locator("#p-problems")).to_be_hidden()
        shown = tablet.evaluate("() => window.problemTexts")
        assert not any("not the questionnaire" in text for text in shown), shown
    assert not errors, errors
    (stored,) = httpx.get(f"{api}/sessions/{sid}/questionnaires").json()
    assert stored["instrument"] == "mssq" and stored["answers"] == given, stored


def test_the_operator_s_sheet_survives_closing_the_dashboard_s_tab(server: str) -> None:
    """Half an NASA-TLX typed in on the operator's form (sliders and pairs), then the dashboard's
    tab is closed and the dashboard opened again: the same session's form comes back with that
    instrument, phase and answers; another session's form is empty; once stored, the draft is gone."""
    from playwright.sync_api import expect, sync_playwright

    api = f"{server}/api/v1"
    pid = httpx.post(f"{api}/participants", json={"code": "D01"}).json()["id"]
    sid = httpx.post(f"{api}/sessions", json={"participant_id": pid, "condition": "EC"}).json()["id"]
    other = httpx.post(f"{api}/sessions", json={"participant_id": pid, "condition": "CC"}).json()["id"]
    with sync_playwright() as pw, chromium(pw) as browser:
        errors: list[str] = []
        context = browser.new_context(viewport=OPERATOR)  # one browser profile, its tabs closed and opened

        def new_tab() -> Any:
            tab = context.new_page()
            tab.on("pageerror", lambda exc: errors.append(f"operator: {exc}"))
            return tab

        page = new_tab()
        form = page.locator("#questionnaire-mount")

        def open_form(session_id: int) -> None:
            row = page.locator(f'#session-table tbody tr[data-session-id="{session_id}"]')
            row.locator("button.session-select").click()
            expect(page.locator("#q-session")).to_contain_text(f"session {session_id}")

        page.goto(server)
        open_form(sid)
        form.locator("#q-instrument").select_option("nasa_tlx")
        expect(form.locator("#q-phase")).to_have_value("post")
        for key, value in list(TLX.items())[:3]:
            form.locator(f'input[type="range"][name="{key}"]').fill(str(value))
        fill_radios(page, {f"{a}_vs_{b}": a for a, b in TLX_PAIRS[:5]})
        page.close()  # the dashboard's tab is closed ...
        page = new_tab()  # ... and the dashboard opened again in a new one
        form = page.locator("#questionnaire-mount")
        page.goto(server)
        open_form(other)
        expect(form.locator("#q-instrument")).to_have_value("")  # another session: nothing carried over
        open_form(sid)
        expect(form.locator("#q-instrument")).to_have_value("nasa_tlx")
        expect(form.locator("#q-phase")).to_have_value("post")
        moved = form.locator('input[type="range"][data-touched="true"]')
        expect(moved).to_have_count(3)
        for key, value in list(TLX.items())[:3]:
            expect(form.locator(f'input[type="range"][name="{key}"]')).to_have_value(str(value))
        expect(form.locator('input[type="radio"]:checked')).to_have_count(5)
        for key, value in list(TLX.items())[3:]:
            form.locator(f'input[type="range"][name="{key}"]').fill(str(value))
        fill_radios(page, {f"{a}_vs_{b}": a for a, b in TLX_PAIRS[5:]})
        form.locator("#q-submit").click()
        expect(form.locator("#q-error")).to_contain_text("has not started")  # a paper sheet entered early
        form.locator("#q-correct-reason").fill("paper sheet typed in before the run")
        form.locator("#q-correct").click()
        expect(form.locator("#q-scores")).to_contain_text("weighted_tlx")
        page.reload()
        open_form(sid)
        expect(form.locator("#q-instrument")).to_have_value("")  # stored: no draft any more
    assert not errors, errors
    (stored,) = httpx.get(f"{api}/sessions/{sid}/questionnaires").json()
    assert stored["answers"] == TLX and stored["entered_by"] == "operator", stored


def test_a_participant_code_is_corrected_on_the_dashboard_with_a_reason(server: str) -> None:
    """The rename button asks for the corrected code, then the reason; the audit trail keeps both."""
    from playwright.sync_api import expect, sync_playwright

    api = f"{server}/api/v1"
    pid = httpx.post(f"{api}/participants", json={"code": "Q017"}).json()["id"]
    answers = iter(["Q071", "typo at sign-up"])
    with sync_playwright() as pw, chromium(pw) as browser:
        page = browser.new_page(viewport=OPERATOR)
        page.on("dialog", lambda d: d.accept(next(answers)))
        page.goto(server)
        row = page.locator("#participant-table tbody tr", has_text="Q017")
        row.locator("button.participant-rename").click()
        expect(page.locator("#participant-table tbody")).to_contain_text("Q071", timeout=20_000)
        expect(page.locator("#participant-table tbody")).not_to_contain_text("Q017")
    assert httpx.get(f"{api}/participants/{pid}").json()["code"] == "Q071"
    trail = httpx.get(f"{api}/audit", params={"entity": "participant", "entity_id": pid}).json()
    assert trail and trail[0]["reason"] == "typo at sign-up", trail
    assert trail[0]["before"]["code"] == "Q017" and trail[0]["after"]["code"] == "Q071", trail


def test_back_up_now_on_the_dashboard(server: str) -> None:
    """*Back up now* makes a checked copy and the panel shows it as the last backup."""
    from playwright.sync_api import expect, sync_playwright

    api = f"{server}/api/v1"
    before = {b["name"] for b in httpx.get(f"{api}/backups").json()["backups"]}
    with sync_playwright() as pw, chromium(pw) as browser:
        errors: list[str] = []
        page = watched_page(browser, errors, "operator", viewport=OPERATOR)
        page.goto(server)
        expect(page.locator("#backup-state")).to_contain_text("kept in")
        # beside the database (the default folder): the panel says a disk failure takes both
        expect(page.locator("#backup-state")).to_contain_text("on the database's own disk")
        page.locator("#backup-now").click()
        expect(page.locator("#toast")).to_contain_text("backed up:")
        expect(page.locator("#backup-state")).to_contain_text("(manual)")
    assert not errors, errors
    after = httpx.get(f"{api}/backups").json()
    (new,) = [b for b in after["backups"] if b["name"] not in before]
    assert new["reason"] == "manual" and after["last"]["name"] == new["name"]
    assert (Path(after["folder"]) / new["name"]).stat().st_size == new["size_bytes"] > 0


def test_a_failed_backup_is_shown_in_red_on_the_dashboard(tmp_path: Path) -> None:
    """A backup folder that cannot be made (here a file is in its place): *Back up now* says why,
    and the panel shows the failure in red until a backup succeeds."""
    from playwright.sync_api import expect, sync_playwright

    from tests.app.conftest import Served, make_settings

    blocker = tmp_path / "usb-stick"
    blocker.write_text("not a folder")
    settings = make_settings(tmp_path)
    settings = settings.model_copy(update={"backup": settings.backup.model_copy(update={"folder": blocker})})
    with Served(settings, autostart=None, pipeline_factory=None) as served, sync_playwright() as pw:
        with chromium(pw) as browser:
            errors: list[str] = []
            page = watched_page(browser, errors, "operator", viewport=OPERATOR)
            page.goto(served.base)
            expect(page.locator("#backup-state")).to_contain_text("No backup yet")
            page.locator("#backup-now").click()
            expect(page.locator("#toast")).to_contain_text("cannot create the backup folder")
            state = page.locator("#backup-state")
            expect(state).to_contain_text("Backup FAILED")
            expect(state).to_have_class("backup-state failed")
            color = state.evaluate("e => getComputedStyle(e).color")
        assert not errors, errors
    assert color == "rgb(220, 38, 38)"  # --bad


def test_a_nearly_full_disk_is_shown_in_the_top_bar_and_a_banner(tmp_path: Path) -> None:
    """storage.min_free_gb above this machine's free space: the top bar's free space turns red and a
    banner says takes and backups wait; *Back up now* is refused with the reason."""
    from playwright.sync_api import expect, sync_playwright

    from tests.app.conftest import Served, make_settings

    settings = make_settings(tmp_path)
    full = settings.storage.model_copy(update={"warn_free_gb": 1e6, "min_free_gb": 1e6})
    with Served(
        settings.model_copy(update={"storage": full}), autostart=None, pipeline_factory=None
    ) as served:
        with sync_playwright() as pw, chromium(pw) as browser:
            errors: list[str] = []
            page = watched_page(browser, errors, "operator", viewport=OPERATOR)
            page.goto(served.base)
            expect(page.locator("#disk-free")).to_contain_text("GB free")
            expect(page.locator("#disk")).to_have_attribute("data-level", "full")
            banner = page.locator("#storage-alarm")
            expect(banner).to_be_visible()
            expect(banner).to_contain_text("Disk nearly full")
            expect(banner).to_contain_text("min_free_gb")
            color = page.locator("#disk-free").evaluate("e => getComputedStyle(e).color")
            page.locator("#backup-now").click()
            expect(page.locator("#toast")).to_contain_text("a backup refused")
        assert not errors, errors
    assert color == "rgb(220, 38, 38)"  # --bad
