"""Issue 15 D3 / D3b through HTTP on a real SQLite file: strict types, and the study design's rules
(each a 409/422 with a message, unless the operator overrides it, and then the override is logged).

Every case here failed on main before the fix (the table in the study engineer's report).
"""

from __future__ import annotations

from typing import Any

import pytest
from fastapi.testclient import TestClient

from app.study.questionnaires import DEFINITIONS, SSQ_KEYS

API = "/api/v1"
IPQ = {i.key: 3 for i in DEFINITIONS["ipq"].items}


def ssq(value: Any = 0, **over: Any) -> dict[str, Any]:
    return {**dict.fromkeys(SSQ_KEYS, value), **over}


def stored(c: TestClient) -> dict[str, Any]:
    """Everything a rejected request must leave as it was."""
    sessions = c.get(f"{API}/sessions").json()
    return {
        "participants": c.get(f"{API}/participants").json(),
        "sessions": sessions,
        "questionnaires": [c.get(f"{API}/sessions/{s['id']}/questionnaires").json() for s in sessions],
        "audit": c.get(f"{API}/audit").json(),
    }


@pytest.fixture()
def study(client: TestClient) -> tuple[TestClient, int, int, int]:
    """P01 (CC first) with a planned CC session holding its SSQ pre, and a planned EC session;
    P02 (EC first) with no session yet."""
    pid = client.post(f"{API}/participants", json={"code": "P01", "first_condition": "CC"}).json()["id"]
    client.post(f"{API}/participants", json={"code": "P02", "first_condition": "EC"})
    cc = client.post(f"{API}/sessions", json={"participant_id": pid, "condition": "CC"}).json()["id"]
    ec = client.post(f"{API}/sessions", json={"participant_id": pid, "condition": "EC"}).json()["id"]
    r = client.post(f"{API}/sessions/{cc}/questionnaires", json={"instrument": "ssq", "phase": "pre",
                                                                "answers": ssq(1)})
    assert r.status_code == 201, r.text
    return client, pid, cc, ec


REFUSED: list[tuple[str, str, str, Any, int, str]] = [
    # D3: booleans and numeric strings where numbers or ids belong
    ("ssq answer true", "POST", "/sessions/{ec}/questionnaires",
     {"instrument": "ssq", "phase": "pre", "answers": ssq(0, general_discomfort=True)}, 422,
     "general_discomfort"),
    ("ssq answer '1'", "POST", "/sessions/{ec}/questionnaires",
     {"instrument": "ssq", "phase": "pre", "answers": ssq(0, fatigue="1")}, 422, "fatigue"),
    ("ssq answer 1.0", "POST", "/sessions/{ec}/questionnaires",
     {"instrument": "ssq", "phase": "pre", "answers": ssq(0, fatigue=1.0)}, 422, "fatigue"),
    ("participant_id true", "POST", "/sessions", {"participant_id": True, "condition": "EC"}, 422,
     "participant_id"),
    ("participant_id '1'", "POST", "/sessions", {"participant_id": "1", "condition": "EC"}, 422,
     "participant_id"),
    ("planned_index true", "POST", "/sessions",
     {"participant_id": "{pid}", "condition": "EC", "planned_index": True}, 422, "planned_index"),
    # D3b: data no study can have
    ("same SSQ pre twice", "POST", "/sessions/{cc}/questionnaires",
     {"instrument": "ssq", "phase": "pre", "answers": ssq(2)}, 409, "already has SSQ pre"),
    ("questionnaire for a session never started", "POST", "/sessions/{ec}/questionnaires",
     {"instrument": "ipq", "phase": "post", "answers": IPQ}, 409, "has not started"),
    ("SSQ post for a session never started", "POST", "/sessions/{cc}/questionnaires",
     {"instrument": "ssq", "phase": "post", "answers": ssq(0)}, 409, "has not started"),
    ("a second CC session", "POST", "/sessions", {"participant_id": "{pid}", "condition": "CC"}, 409,
     "already has a CC session"),
    ("planned_index 2 for the first condition", "POST", "/sessions",
     {"participant_id": "{p2}", "condition": "EC", "planned_index": 2}, 409, "contradicts"),
    ("p01 and P01", "POST", "/participants", {"code": "p01"}, 409, "already exists as 'P01'"),
    ("NUL in participant notes", "POST", "/participants", {"code": "P03", "notes": "a\u0000b"}, 422,
     "U+0000"),
    ("NUL in session notes", "PATCH", "/sessions/{cc}", {"notes": "x\u0000"}, 422, "U+0000"),
    ("no phase", "POST", "/sessions/{ec}/questionnaires",
     {"instrument": "ipq", "answers": IPQ}, 422, "phase is required"),
]  # fmt: skip


def fill(value: Any, ids: dict[str, int]) -> Any:
    if isinstance(value, str) and value in ("{pid}", "{p2}", "{cc}", "{ec}"):
        return ids[value[1:-1]]
    if isinstance(value, dict):
        return {k: fill(v, ids) for k, v in value.items()}
    return value


@pytest.mark.parametrize(("method", "path", "body", "code", "text"), [r[1:] for r in REFUSED],
                         ids=[r[0] for r in REFUSED])  # fmt: skip
def test_refused_with_a_message_and_nothing_stored(
    study: tuple[TestClient, int, int, int], method: str, path: str, body: Any, code: int, text: str
) -> None:
    c, pid, cc, ec = study
    ids = {"pid": pid, "p2": pid + 1, "cc": cc, "ec": ec}
    before = stored(c)
    r = c.request(method, API + path.format(**ids), json=fill(body, ids))
    assert r.status_code == code, r.text
    assert text in r.text, f"the message should say {text!r}: {r.text}"
    assert stored(c) == before, "a refused request changes nothing"


def test_a_duplicate_is_refused_then_corrected_with_a_reason(study: tuple[TestClient, int, int, int]) -> None:
    """Issue 19.2: a second SSQ pre is a 409; sent as a correction with a reason it replaces the first,
    which is kept, marked superseded, and the audit trail has both versions."""
    c, _pid, cc, _ec = study
    first = c.get(f"{API}/sessions/{cc}/questionnaires").json()[0]
    body = {"instrument": "ssq", "phase": "pre", "answers": ssq(2)}
    r = c.post(f"{API}/sessions/{cc}/questionnaires", json=body)
    assert r.status_code == 409 and f'"correction_of": {first["id"]}' in r.json()["detail"], r.text
    r = c.post(f"{API}/sessions/{cc}/questionnaires", json={**body, "correction_of": first["id"]})
    assert r.status_code == 409 and "reason" in r.text, "a correction without a reason is refused"
    r = c.post(f"{API}/sessions/{cc}/questionnaires",
               json={**body, "correction_of": first["id"], "reason": "entered on the wrong form", "by": "AB"})
    assert r.status_code == 201, r.text
    new = r.json()
    assert new["corrects_id"] == first["id"] and new["correction_reason"] == "entered on the wrong form"
    entries = {q["id"]: q for q in c.get(f"{API}/sessions/{cc}/questionnaires").json()}
    assert entries[first["id"]]["superseded_by_id"] == new["id"] and not entries[first["id"]]["in_use"]
    assert entries[new["id"]]["in_use"]
    (audit,) = c.get(f"{API}/audit", params={"entity": "questionnaire"}).json()
    assert (audit["action"], audit["actor"]) == ("correct", "AB")
    assert audit["reason"] == "entered on the wrong form"
    assert audit["before"]["scores"]["total"] == pytest.approx(21 * 3.74)
    assert audit["after"]["scores"]["total"] == pytest.approx(42 * 3.74)
    # the replaced entry cannot be corrected again: the correction of a correction names the new one
    r = c.post(f"{API}/sessions/{cc}/questionnaires",
               json={**body, "correction_of": first["id"], "reason": "again"})
    assert r.status_code == 409 and "replaced" in r.text


@pytest.mark.parametrize(
    ("what", "request_"),
    [
        ("a second CC session", ("POST", "/sessions", {"participant_id": "{pid}", "condition": "CC"})),
        ("IPQ before the run", ("POST", "/sessions/{ec}/questionnaires",
                                {"instrument": "ipq", "phase": "post", "answers": IPQ})),
        ("planned_index 2 for EC first", ("POST", "/sessions",
                                          {"participant_id": "{p2}", "condition": "EC", "planned_index": 2})),
    ],
)  # fmt: skip
def test_an_override_lets_a_rule_pass_and_is_logged(
    study: tuple[TestClient, int, int, int], what: str, request_: tuple[str, str, dict[str, Any]]
) -> None:
    c, pid, cc, ec = study
    ids = {"pid": pid, "p2": pid + 1, "cc": cc, "ec": ec}
    method, path, body = request_
    r = c.request(method, API + path.format(**ids),
                  json={**fill(body, ids), "override_reason": "pilot participant, by protocol"})
    assert r.status_code == 201, r.text
    audit = [a for a in c.get(f"{API}/audit").json() if a["action"] == "override"]
    assert len(audit) == 1 and audit[0]["reason"] == "pilot participant, by protocol", audit
    assert audit[0]["after"]["rule"] in ("one_session_per_condition", "not_started", "planned_index")
    sid = r.json().get("session_id", r.json()["id"])
    events = c.get(f"{API}/sessions/{sid}/events", params={"kind": "override"}).json()
    assert len(events) == 1 and events[0]["payload"]["reason"] == "pilot participant, by protocol"


def test_first_condition_is_fixed_once_a_session_ran(study: tuple[TestClient, int, int, int]) -> None:
    c, pid, cc, ec = study
    r = c.patch(f"{API}/participants/{pid}", json={"first_condition": "EC"})
    assert r.status_code == 200, "before any session ran the order may change"
    sessions = {s["id"]: s for s in c.get(f"{API}/sessions").json()}
    assert (sessions[ec]["planned_index"], sessions[cc]["planned_index"]) == (1, 2), "planned sessions follow"
    c.patch(f"{API}/participants/{pid}", json={"first_condition": "CC"})
    assert c.post(f"{API}/sessions/{cc}/start").status_code == 200
    assert c.post(f"{API}/sessions/{cc}/stop").status_code == 200
    before = stored(c)
    r = c.patch(f"{API}/participants/{pid}", json={"first_condition": "EC"})
    assert r.status_code == 409 and "already ran session" in r.text
    assert stored(c) == before
    r = c.patch(f"{API}/participants/{pid}",
                json={"first_condition": "EC", "override_reason": "order was entered the wrong way round"})
    assert r.status_code == 200 and r.json()["first_condition"] == "EC"
    kinds = [(a["action"], a["entity"]) for a in c.get(f"{API}/audit").json()]
    assert ("override", "participant") in kinds and ("update", "participant") in kinds


def test_post_questionnaires_after_the_session_stopped_stay_allowed(
    study: tuple[TestClient, int, int, int],
) -> None:
    c, _pid, cc, _ec = study
    assert c.post(f"{API}/sessions/{cc}/start").status_code == 200
    assert c.post(f"{API}/sessions/{cc}/stop").status_code == 200
    for body in ({"instrument": "ssq", "phase": "post", "answers": ssq(1)},
                 {"instrument": "ipq", "phase": "post", "answers": IPQ}):  # fmt: skip
        r = c.post(f"{API}/sessions/{cc}/questionnaires", json=body)
        assert r.status_code == 201, r.text
    pre = {"instrument": "ssq", "phase": "pre", "answers": ssq(0)}
    r = c.post(f"{API}/sessions/{cc}/questionnaires", json=pre)
    assert r.status_code == 409, "but the session already has its SSQ pre"
