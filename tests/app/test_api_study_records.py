"""Participants, sessions, questionnaires and the session log through HTTP against a real SQLite file."""

from __future__ import annotations

from typing import Any

import pytest
from fastapi.testclient import TestClient

SSQ_KEYS = [
    "general_discomfort",
    "fatigue",
    "headache",
    "eye_strain",
    "difficulty_focusing",
    "increased_salivation",
    "sweating",
    "nausea",
    "difficulty_concentrating",
    "fullness_of_head",
    "blurred_vision",
    "dizzy_eyes_open",
    "dizzy_eyes_closed",
    "vertigo",
    "stomach_awareness",
    "burping",
]


def ssq_answers(value: int = 0, **override: Any) -> dict[str, Any]:
    answers: dict[str, Any] = dict.fromkeys(SSQ_KEYS, value)
    answers.update(override)
    return answers


def state(c: TestClient) -> dict[str, Any]:
    """Everything stored that a request could change."""
    sessions = c.get("/api/v1/sessions").json()
    return {
        "participants": c.get("/api/v1/participants").json(),
        "sessions": sessions,
        "questionnaires": {
            s["id"]: c.get(f"/api/v1/sessions/{s['id']}/questionnaires").json() for s in sessions
        },
        "events": {s["id"]: c.get(f"/api/v1/sessions/{s['id']}/events").json() for s in sessions},
    }


def test_participant_and_session_shapes(client: TestClient) -> None:
    r = client.post("/api/v1/participants", json={"code": "P01"})
    assert r.status_code == 201, r.text
    p = r.json()
    assert p["code"] == "P01" and isinstance(p["id"], int)
    assert [x["code"] for x in client.get("/api/v1/participants").json()] == ["P01"]
    r = client.post("/api/v1/sessions", json={"participant_id": p["id"], "condition": "CC"})
    assert r.status_code == 201, r.text
    s = r.json()
    assert s["status"] == "planned" and s["participant_code"] == "P01"
    # P01 got CC first (counterbalancing), so a CC session is the first one planned
    assert s["planned_index"] == (1 if p["first_condition"] == "CC" else 2)


def test_first_conditions_are_counterbalanced(client: TestClient) -> None:
    firsts = [
        client.post("/api/v1/participants", json={"code": f"P{i:02d}"}).json()["first_condition"]
        for i in range(1, 7)
    ]
    assert firsts.count("CC") == 3 and firsts.count("EC") == 3, firsts
    assert all(firsts[i] != firsts[i + 1] for i in range(0, 6, 2)), f"each pair is balanced: {firsts}"
    # an explicit choice is kept and counted
    explicit = client.post("/api/v1/participants", json={"code": "X1", "first_condition": "EC"}).json()
    assert explicit["first_condition"] == "EC"
    assert client.post("/api/v1/participants", json={"code": "X2"}).json()["first_condition"] == "CC"


def test_session_lifecycle_logs_events(client: TestClient) -> None:
    pid = client.post("/api/v1/participants", json={"code": "P01"}).json()["id"]
    sid = client.post("/api/v1/sessions", json={"participant_id": pid, "condition": "EC"}).json()["id"]
    assert client.post(f"/api/v1/sessions/{sid}/start").json()["status"] == "running"
    r = client.patch(f"/api/v1/sessions/{sid}", json={"notes": "participant wore glasses"})
    assert r.json()["notes"] == "participant wore glasses"
    client.app.state.events.record("action", {"label": "forward"})  # what the pipeline forwards
    stopped = client.post(f"/api/v1/sessions/{sid}/stop").json()
    assert stopped["status"] == "stopped" and stopped["stopped_at"] >= stopped["started_at"]
    client.app.state.events.record("action", {"label": "left"})  # after the stop: not this session's
    events = client.get(f"/api/v1/sessions/{sid}/events").json()
    assert [(e["kind"], e["payload"].get("state") or e["payload"]) for e in events] == [
        ("session", "running"),
        ("action", {"label": "forward"}),
        ("session", "stopped"),
    ]
    start = events[0]["payload"]
    assert start["pose_model"].startswith("yolo11n-pose") and "calibration_id" in start, (
        "the start event names the calibration and the models used (issue 19.10)"
    )
    assert [e["ts"] for e in events] == sorted(e["ts"] for e in events)
    assert client.get(f"/api/v1/sessions/{sid}/events", params={"kind": "action"}).json()[0]["payload"] == {
        "label": "forward"
    }


def test_questionnaire_is_scored_and_stored_with_raw_answers(client: TestClient) -> None:
    pid = client.post("/api/v1/participants", json={"code": "P01"}).json()["id"]
    sid = client.post("/api/v1/sessions", json={"participant_id": pid, "condition": "CC"}).json()["id"]
    client.post(f"/api/v1/sessions/{sid}/start")
    client.post(f"/api/v1/sessions/{sid}/stop")
    answers = ssq_answers(0, nausea=2, headache=1, vertigo=3)
    r = client.post(
        f"/api/v1/sessions/{sid}/questionnaires",
        json={"instrument": "ssq", "phase": "post", "answers": answers},
    )
    assert r.status_code == 201, r.text
    body = r.json()
    assert set(body["scores"]) >= {"nausea", "oculomotor", "disorientation", "total"}
    # Kennedy 1993 by hand: nausea loads N and D; headache O; vertigo D.
    n_raw, o_raw, d_raw = 2, 1, 2 + 3
    assert body["scores"]["nausea"] == pytest.approx(n_raw * 9.54, abs=0.01)
    assert body["scores"]["oculomotor"] == pytest.approx(o_raw * 7.58, abs=0.01)
    assert body["scores"]["disorientation"] == pytest.approx(d_raw * 13.92, abs=0.01)
    assert body["scores"]["total"] == pytest.approx((n_raw + o_raw + d_raw) * 3.74, abs=0.01)
    stored = client.get(f"/api/v1/sessions/{sid}/questionnaires").json()
    assert len(stored) == 1 and stored[0]["answers"] == answers and stored[0]["id"] == body["id"]


@pytest.fixture()
def populated(client: TestClient) -> tuple[TestClient, int, int]:
    pid = client.post("/api/v1/participants", json={"code": "P01"}).json()["id"]
    sid = client.post("/api/v1/sessions", json={"participant_id": pid, "condition": "CC"}).json()["id"]
    client.post(
        f"/api/v1/sessions/{sid}/questionnaires",
        json={"instrument": "ssq", "phase": "pre", "answers": ssq_answers(1)},
    )
    return client, pid, sid


BAD_REQUESTS: list[tuple[str, str, str, Any, int, str]] = [
    # (id, method, path, json body, status, text the message must contain)
    ("duplicate code", "POST", "/api/v1/participants", {"code": "P01"}, 409, "already exists"),
    ("name instead of code", "POST", "/api/v1/participants", {"code": "Jane Doe"}, 422, "pattern"),
    ("code too long", "POST", "/api/v1/participants", {"code": "x" * 33}, 422, "pattern"),
    ("unknown field", "POST", "/api/v1/participants", {"code": "P9", "email": "a@b"}, 422, "email"),
    ("bad condition", "POST", "/api/v1/sessions", {"participant_id": 1, "condition": "VR"}, 422, "condition"),
    (
        "unknown participant",
        "POST",
        "/api/v1/sessions",
        {"participant_id": 99, "condition": "CC"},
        404,
        "participant 99",
    ),
    ("stop a planned session", "POST", "/api/v1/sessions/1/stop", None, 409, "only a running session"),
    ("start unknown session", "POST", "/api/v1/sessions/42/start", None, 404, "session 42"),
    (
        "ssq value out of range",
        "POST",
        "/api/v1/sessions/1/questionnaires",
        {"instrument": "ssq", "phase": "post", "answers": ssq_answers(0, sweating=4)},
        422,
        "sweating",
    ),
    (
        "ssq missing item",
        "POST",
        "/api/v1/sessions/1/questionnaires",
        {"instrument": "ssq", "phase": "post", "answers": {k: 0 for k in SSQ_KEYS if k != "burping"}},
        422,
        "burping",
    ),
    (
        "ssq unknown key",
        "POST",
        "/api/v1/sessions/1/questionnaires",
        {"instrument": "ssq", "phase": "post", "answers": ssq_answers(0, sneezing=1)},
        422,
        "sneezing",
    ),
    (
        "unknown instrument",
        "POST",
        "/api/v1/sessions/1/questionnaires",
        {"instrument": "panas", "phase": None, "answers": {}},
        422,
        "instrument",
    ),
    (
        "questionnaire for unknown session",
        "POST",
        "/api/v1/sessions/77/questionnaires",
        {"instrument": "ssq", "phase": "pre", "answers": ssq_answers(0)},
        404,
        "session 77",
    ),
    ("notes not a string", "PATCH", "/api/v1/sessions/1", {"notes": 5}, 422, "notes"),
]


@pytest.mark.parametrize(
    ("method", "path", "body", "code", "text"),
    [b[1:] for b in BAD_REQUESTS],
    ids=[b[0] for b in BAD_REQUESTS],
)
def test_bad_input_is_4xx_with_a_message_and_changes_nothing(
    populated: tuple[TestClient, int, int], method: str, path: str, body: Any, code: int, text: str
) -> None:
    c, _pid, _sid = populated
    before = state(c)
    r = c.request(method, path, json=body)
    assert r.status_code == code, r.text
    assert text in r.text, f"the message should name {text!r}: {r.text}"
    assert state(c) == before, "a rejected request must leave the stored state unchanged"


def test_only_one_session_runs_at_a_time(populated: tuple[TestClient, int, int]) -> None:
    c, pid, sid = populated
    other = c.post("/api/v1/sessions", json={"participant_id": pid, "condition": "EC"}).json()["id"]
    assert c.post(f"/api/v1/sessions/{sid}/start").status_code == 200
    before = state(c)
    r = c.post(f"/api/v1/sessions/{other}/start")
    assert r.status_code == 409 and f"session {sid} is still running" in r.text
    assert state(c) == before
