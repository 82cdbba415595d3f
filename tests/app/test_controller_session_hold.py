"""A controller (``CC``) session holds navigation while it runs ([study] hold_controller_sessions), on the
real app and a real SQLite file: started, navigation is held as the session's own hold (status
``held_by`` "session", the hold file names it); stopped by the operator or by its timer, it is
released and the session's log has both changes; the operator's own hold is never taken over, and
the operator may release the session's; a server started again keeps a running session's hold and
releases one whose session has stopped."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from fastapi.testclient import TestClient

from app.main import create_app
from app.services.live import HOLD_FILE
from app.study.config import StudyConfig
from tests.app.conftest import make_settings
from tests.waiting import wait_until

API = "/api/v1"


def session(client: TestClient, code: str, condition: str, **extra: Any) -> int:
    pid = client.post(f"{API}/participants", json={"code": code}).json()["id"]
    r = client.post(f"{API}/sessions", json={"participant_id": pid, "condition": condition, **extra})
    assert r.status_code == 201, r.text
    return int(r.json()["id"])


def hold(client: TestClient) -> tuple[bool, str | None]:
    held = client.get(f"{API}/navigation/hold").json()["held"]
    return held, client.get(f"{API}/status").json()["held_by"]


def hold_events(client: TestClient, sid: int) -> list[tuple[bool, str]]:
    events = client.get(f"{API}/sessions/{sid}/events").json()
    return [(e["payload"]["held"], e["payload"]["by"]) for e in events if e["kind"] == "hold"]


def test_a_controller_session_holds_while_it_runs_and_its_stop_releases(
    client: TestClient, tmp_path: Path
) -> None:
    kept = tmp_path / HOLD_FILE
    cc = session(client, "CC1", "CC")
    assert client.post(f"{API}/sessions/{cc}/start").status_code == 200
    assert hold(client) == (True, "session")
    assert kept.read_text() == f"held\nsession {cc}\n"
    r = client.put(f"{API}/navigation/hold", json={"held": "no"})  # bad input changes nothing
    assert r.status_code == 422 and hold(client) == (True, "session")
    time.sleep(0.2)
    assert client.post(f"{API}/sessions/{cc}/stop").status_code == 200
    assert hold(client) == (False, None) and not kept.exists()
    assert hold_events(client, cc) == [(True, "session"), (False, "session")]
    events = client.get(f"{API}/sessions/{cc}/events").json()
    said = [e["payload"]["message"] for e in events if e["kind"] == "hold"]
    assert said == [f"navigation held for controller session {cc}: the workstations get still",
                    f"navigation released: controller session {cc} stopped"], said
    summary = client.get(f"{API}/sessions/{cc}/summary").json()
    assert summary["holds"] == 1 and 0 < summary["held_s"] <= summary["duration_s"], summary

    ec = session(client, "EC1", "EC")  # the embodied condition: the body navigates
    assert client.post(f"{API}/sessions/{ec}/start").status_code == 200
    assert hold(client) == (False, None)
    assert client.post(f"{API}/sessions/{ec}/stop").status_code == 200
    assert hold_events(client, ec) == []


def test_the_operators_hold_stays_the_operators(client: TestClient, tmp_path: Path) -> None:
    kept = tmp_path / HOLD_FILE
    assert client.put(f"{API}/navigation/hold", json={"held": True}).json()["changed"] is True
    first = session(client, "OP1", "CC")  # held before it starts: its stop leaves the hold on
    assert client.post(f"{API}/sessions/{first}/start").status_code == 200
    assert hold(client) == (True, "operator")
    assert client.post(f"{API}/sessions/{first}/stop").status_code == 200
    assert hold(client) == (True, "operator") and kept.read_text() == "held\n"
    assert client.put(f"{API}/navigation/hold", json={"held": False}).json()["changed"] is True

    second = session(client, "OP2", "CC")  # the operator releases the session's hold: not held again
    assert client.post(f"{API}/sessions/{second}/start").status_code == 200
    assert client.put(f"{API}/navigation/hold", json={"held": False}).json()["changed"] is True
    assert client.post(f"{API}/sessions/{second}/stop").status_code == 200
    assert hold(client) == (False, None)
    assert hold_events(client, second) == [(True, "session"), (False, "operator")]

    third = session(client, "OP3", "CC")  # asked for while the session holds: the operator's now
    assert client.post(f"{API}/sessions/{third}/start").status_code == 200
    r = client.put(f"{API}/navigation/hold", json={"held": True})
    assert r.json() == {"held": True, "changed": False}, r.text
    assert hold(client) == (True, "operator") and kept.read_text() == "held\n"
    assert client.post(f"{API}/sessions/{third}/stop").status_code == 200
    assert hold(client) == (True, "operator")
    assert hold_events(client, third) == [(True, "session"), (True, "operator")]


def test_a_controller_session_stopped_by_its_timer_releases(client: TestClient) -> None:
    cc = session(client, "TIM1", "CC", planned_duration_s=5)
    assert client.post(f"{API}/sessions/{cc}/start").status_code == 200
    assert hold(client) == (True, "session")
    wait_until(lambda: client.get(f"{API}/sessions/{cc}").json()["status"] == "stopped" or None,
               "the server stops the session at the end of its run time", timeout_s=30)
    wait_until(lambda: hold(client) == (False, None) or None, "its hold released")
    assert hold_events(client, cc) == [(True, "session"), (False, "session")]


def test_a_server_started_again_keeps_a_running_sessions_hold_and_drops_a_stopped_ones(
    tmp_path: Path,
) -> None:
    settings = make_settings(tmp_path)
    kept = tmp_path / HOLD_FILE
    with TestClient(create_app(settings, pipeline_factory=None)) as client:
        cc = session(client, "RS1", "CC")
        assert client.post(f"{API}/sessions/{cc}/start").status_code == 200
    with TestClient(create_app(settings, pipeline_factory=None)) as client:  # the session runs on
        assert hold(client) == (True, "session")
        assert client.post(f"{API}/sessions/{cc}/stop").status_code == 200
        assert hold(client) == (False, None)
    kept.write_text(f"held\nsession {cc}\n")  # a crash between the stop and the release
    with TestClient(create_app(settings, pipeline_factory=None)) as client:
        assert hold(client) == (False, None) and not kept.exists()
    kept.write_text("held\nsession 99999\n")  # no such session running either
    with TestClient(create_app(settings, pipeline_factory=None)) as client:
        assert hold(client) == (False, None)


def test_the_setting_off_leaves_controller_sessions_unheld(tmp_path: Path) -> None:
    off = StudyConfig(hold_controller_sessions=False)
    settings = make_settings(tmp_path).model_copy(update={"study": off})
    with TestClient(create_app(settings, pipeline_factory=None)) as client:
        cc = session(client, "OFF1", "CC")
        assert client.post(f"{API}/sessions/{cc}/start").status_code == 200
        assert hold(client) == (False, None)
