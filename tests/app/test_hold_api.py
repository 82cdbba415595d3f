"""The operator's hold through the API, on the real app and runtime: the simulator's stepping user,
served by uvicorn, a real UDP socket as the workstation. Held, every locomotion datagram says still
while the recogniser goes on saying the user steps, also across a pipeline rebuilt for a model;
released, the walls move again; the session's log and summary count the hold; bad requests change
nothing."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import httpx
import pytest

from app.services.live import HOLD_FILE
from tests.app.conftest import Served, make_settings
from tests.datagrams import DatagramRecorder
from tests.waiting import HTTP_TIMEOUT_S, wait_until

pytestmark = pytest.mark.slow

http = httpx.Client(timeout=HTTP_TIMEOUT_S)
IN_FLIGHT_S = 0.3  # a datagram built before the hold was set is read by then (loopback)


def moving(messages: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [m for m in messages if m["type"] == "locomotion" and m["action"] != "still"]


def said_and_kept(messages: list[dict[str, Any]]) -> list[bool]:
    """The ``hold`` announcements in order, checking what a workstation may rely on: after
    ``held: true`` every locomotion says still until ``held: false``."""
    said, held = [], False
    for m in messages:
        if m["type"] == "hold":
            said.append(held := bool(m["held"]))
        elif m["type"] == "locomotion" and held:
            assert m["action"] == "still", f"a movement after the hold was said: {m}"
    return said


def steps_while_held(status: dict[str, Any]) -> bool:
    return bool(status["held"]) and status["action"] is not None and status["action"]["label"] != "still"


def test_a_held_navigation_sends_still_whatever_the_user_does_until_released(tmp_path: Path) -> None:
    rx = DatagramRecorder()
    settings = make_settings(tmp_path).model_copy(update={"workstations": [f"127.0.0.1:{rx.port}"]})
    try:
        with Served(settings) as served:
            base = f"{served.base}/api/v1"
            assert http.get(f"{base}/navigation/hold").json() == {"held": False, "changed": False}
            wait_until(lambda: moving([m for _, m in rx.got]) or None, "the stepping user moves the walls")
            pid = http.post(f"{base}/participants", json={"code": "HOLD1"}).json()["id"]
            sid = http.post(f"{base}/sessions", json={"participant_id": pid, "condition": "EC"}).json()["id"]
            assert http.post(f"{base}/sessions/{sid}/start").status_code == 200

            r = http.put(f"{base}/navigation/hold", json={"held": True})
            assert r.status_code == 200 and r.json() == {"held": True, "changed": True}, r.text
            time.sleep(IN_FLIGHT_S)
            mark = len(rx.got)
            # the recogniser goes on: it says the user steps while the walls get still
            served.wait_status(steps_while_held)

            # a pipeline rebuilt for a model (Restart now) holds too
            active = http.get(f"{base}/models/active").json()
            assert http.post(f"{base}/models/{active['id']}/activate").status_code == 200
            assert http.post(f"{base}/pipeline/restart").status_code == 200
            rebuilt = len(rx.got)
            served.wait_status(lambda s: s["state"] == "running" and steps_while_held(s))
            wait_until(lambda: rx.locomotion_since(rebuilt) > 60 or None, "the rebuilt pipeline's stream")

            assert http.put(f"{base}/navigation/hold", json={"held": True}).json() == {"held": True,
                                                                                       "changed": False}
            for body in ({"held": "yes"}, {"held": 1}, {}, {"held": True, "until": 3}, [True]):
                r = http.put(f"{base}/navigation/hold", json=body)
                assert r.status_code == 422 and r.json()["detail"], (body, r.text)
            r = http.put(f"{base}/navigation/hold", content=b"{not json",
                         headers={"Content-Type": "application/json"})
            assert r.status_code == 422, r.text
            assert http.get(f"{base}/navigation/hold").json()["held"] is True, "a rejected request holds on"

            end = len(rx.got)
            r = http.put(f"{base}/navigation/hold", json={"held": False})
            assert r.status_code == 200 and r.json() == {"held": False, "changed": True}, r.text
            wait_until(lambda: moving([m for _, m in rx.got[end:]]) or None, "the walls move again")
            assert served.wait_status(lambda s: True)["held"] is False
            assert http.post(f"{base}/sessions/{sid}/stop").status_code == 200
            summary = http.get(f"{base}/sessions/{sid}/summary").json()
            events = http.get(f"{base}/sessions/{sid}/events").json()
    finally:
        rx.close()
    held = [m for _, m in rx.got[mark:end] if m["type"] == "locomotion"]
    assert len(held) > 60, f"the stream went on while held ({len(held)} locomotion datagrams)"
    assert not moving(held), f"held: every locomotion datagram says still, got {moving(held)[:3]}"
    assert {m["speed_mps"] for m in held} == {0.0} and {m["confidence"] for m in held} == {1.0}
    assert [e["payload"]["held"] for e in events if e["kind"] == "hold"] == [True, False], events
    said = said_and_kept([m for _, m in rx.got])
    first_off = said.index(False)  # each sender says a change once (two senders: twice)
    assert first_off > 0 and set(said[:first_off]) == {True} and set(said[first_off:]) == {False}, said
    assert summary["holds"] == 1 and summary["held_s"] > 0, summary
    assert summary["held_s"] <= summary["duration_s"], summary


def test_a_hold_outlives_the_server_process(tmp_path: Path) -> None:
    """A server stopped (or crashed) while navigation is held starts again held: from its first
    datagram the walls get still, until the operator releases it."""
    rx = DatagramRecorder()
    settings = make_settings(tmp_path).model_copy(update={"workstations": [f"127.0.0.1:{rx.port}"]})
    kept = settings.paths.db.parent / HOLD_FILE
    try:
        with Served(settings, autostart=None) as served:
            assert http.put(f"{served.base}/api/v1/navigation/hold", json={"held": True}).status_code == 200
        assert kept.read_text() == "held\n"
        before = len(rx.got)
        with Served(settings) as served:  # the simulator starts at once
            base = f"{served.base}/api/v1"
            assert http.get(f"{base}/navigation/hold").json()["held"] is True
            served.wait_status(steps_while_held)
            wait_until(lambda: rx.locomotion_since(before) > 60 or None, "a second of the new stream")
            end = len(rx.got)
            assert http.put(f"{base}/navigation/hold", json={"held": False}).json()["changed"] is True
            assert not kept.exists(), "released: nothing kept for the next server"
            wait_until(lambda: moving([m for _, m in rx.got[end:]]) or None, "the walls move again")
    finally:
        rx.close()
    held = [m for _, m in rx.got[before:end] if m["type"] == "locomotion"]
    assert held and not moving(held), moving(held)[:3]


def test_a_controller_session_holds_the_stream_until_it_stops(tmp_path: Path) -> None:
    """The simulator's user steps all along: while a CC session runs every locomotion datagram says
    still (the session's own hold, said by a hold datagram), and its stop lets the walls move again."""
    rx = DatagramRecorder()
    settings = make_settings(tmp_path).model_copy(update={"workstations": [f"127.0.0.1:{rx.port}"]})
    try:
        with Served(settings) as served:
            base = f"{served.base}/api/v1"
            wait_until(lambda: moving([m for _, m in rx.got]) or None, "the stepping user moves the walls")
            pid = http.post(f"{base}/participants", json={"code": "HOLD3"}).json()["id"]
            sid = http.post(f"{base}/sessions", json={"participant_id": pid, "condition": "CC"}).json()["id"]
            assert http.post(f"{base}/sessions/{sid}/start").status_code == 200
            time.sleep(IN_FLIGHT_S)
            mark = len(rx.got)
            served.wait_status(lambda s: s["held_by"] == "session" and steps_while_held(s))
            wait_until(lambda: rx.locomotion_since(mark) > 90 or None, "1.5 s of the session's stream")
            end = len(rx.got)
            assert http.post(f"{base}/sessions/{sid}/stop").status_code == 200
            wait_until(lambda: moving([m for _, m in rx.got[end:]]) or None, "the walls move again")
            events = http.get(f"{base}/sessions/{sid}/events").json()
    finally:
        rx.close()
    held = [m for _, m in rx.got[mark:end] if m["type"] == "locomotion"]
    assert held and not moving(held), moving(held)[:3]
    said = said_and_kept([m for _, m in rx.got])
    assert said[:1] == [True] and said[-1] is False, said
    assert {m["by"] for _, m in rx.got if m["type"] == "hold" and m["held"]} == {"session"}, "who holds"
    assert [(e["payload"]["held"], e["payload"]["by"]) for e in events if e["kind"] == "hold"] == [
        (True, "session"), (False, "session")], events


def test_a_controller_session_started_before_the_pipeline_holds_its_first_datagram(tmp_path: Path) -> None:
    rx = DatagramRecorder()
    settings = make_settings(tmp_path).model_copy(update={"workstations": [f"127.0.0.1:{rx.port}"]})
    try:
        with Served(settings, autostart=None) as served:
            base = f"{served.base}/api/v1"
            pid = http.post(f"{base}/participants", json={"code": "HOLD4"}).json()["id"]
            sid = http.post(f"{base}/sessions", json={"participant_id": pid, "condition": "CC"}).json()["id"]
            assert http.post(f"{base}/sessions/{sid}/start").status_code == 200
            assert http.post(f"{base}/pipeline/start", json={"source": "simulator"}).status_code == 200
            served.wait_status(lambda s: s["held_by"] == "session" and steps_while_held(s))
            wait_until(lambda: rx.locomotion_since(0) > 60 or None, "a second of the held stream")
            end = len(rx.got)
            assert http.post(f"{base}/sessions/{sid}/stop").status_code == 200
            events = http.get(f"{base}/sessions/{sid}/events").json()
    finally:
        rx.close()
    held = [m for _, m in rx.got[:end] if m["type"] == "locomotion"]
    assert held and not moving(held), moving(held)[:3]
    said = [(e["payload"]["held"], e["payload"]["message"]) for e in events if e["kind"] == "hold"]
    assert said and all(f"controller session {sid}" in message for _, message in said), said
    assert said[0][0] is True and said[-1][0] is False, said
