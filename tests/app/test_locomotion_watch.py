"""The no-locomotion alarm on a clock the test controls, writing to a real event log (SQLite)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from fastapi.testclient import TestClient

from app.db.engine import make_engine, make_session_factory
from app.db.migrate import upgrade
from app.db.repositories import create_participant, create_session, list_events
from app.services.event_log import EventWriter
from app.services.locomotion_watch import LocomotionWatch


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def status(navigator: int | None, action: str | None = "still", state: str = "running",
           mode: str = "auto") -> dict[str, Any]:  # fmt: skip
    return {"state": state, "navigator": navigator, "navigator_mode": mode,
            "action": None if action is None else {"label": action}}  # fmt: skip


def test_alarm_after_two_seconds_without_commands_and_its_events(tmp_path: Path) -> None:
    engine = make_engine(tmp_path / "w.db")
    upgrade(engine)
    factory = make_session_factory(engine)
    with factory() as db:
        sid = create_session(db, create_participant(db, "P01", "CC", "").id, "CC", None, "").id
    events = EventWriter(factory)
    clock = Clock()
    watch = LocomotionWatch(events, clock=clock)
    watch.update(status(3))
    assert watch.current() is None, "no session: no alarm"
    events.set_session(sid)
    for _ in range(30):  # 3 s of commands
        clock.t += 0.1
        watch.update(status(3))
    assert watch.current() is None
    for _ in range(20):  # the navigator is lost: 2.0 s, not yet more than 2 s
        clock.t += 0.1
        watch.update(status(None, None, mode="manual"))
    assert watch.current() is None
    clock.t += 0.2
    watch.update(status(None, None, mode="manual"))
    alarm = watch.current()
    assert alarm is not None and alarm["session_id"] == sid and alarm["gap_s"] == 2.2
    assert alarm["reason"] == "no navigator: the operator's choice is lost"
    clock.t += 1.0
    assert watch.current()["gap_s"] == 3.2, "the gap grows while nothing is sent (no snapshot needed)"  # type: ignore[index]
    clock.t += 2.0
    assert "not running" in watch.current()["reason"], "no status for 2 s: the pipeline is not polled"  # type: ignore[index]
    watch.update(status(5))
    assert watch.current() is None, "commands again: the alarm clears"
    events.flush()
    with factory() as db:
        rows = list_events(db, session_id=sid, kind="alarm")
    assert [r.payload["state"] for r in rows] == ["raised", "cleared"]
    assert rows[1].payload["gap_s"] == 5.2
    engine.dispose()


def test_the_alarm_is_logged_with_nobody_polling_the_status(client: TestClient) -> None:
    """A running session with no pipeline and no dashboard open: the watch's own clock logs it."""
    pid = client.post("/api/v1/participants", json={"code": "P09"}).json()["id"]
    sid = client.post("/api/v1/sessions", json={"participant_id": pid, "condition": "EC"}).json()["id"]
    assert client.post(f"/api/v1/sessions/{sid}/start").status_code == 200
    deadline = time.monotonic() + 30  # > 2 s of silence, plus a loaded machine's slack
    alarms: list[dict[str, Any]] = []
    while time.monotonic() < deadline and not alarms:
        time.sleep(0.25)
        events = client.get(f"/api/v1/sessions/{sid}/events").json()  # the log, not the live status
        alarms = [e for e in events if e["kind"] == "alarm"]
    assert alarms, "no alarm event although nothing was sent for more than 2 s"
    payload = alarms[0]["payload"]
    assert payload["state"] == "raised" and payload["reason"] == "the pipeline is not running"
